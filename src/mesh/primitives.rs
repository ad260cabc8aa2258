//! Simple closed and open meshes with known geometry, for tests, benchmarks
//! and the synthetic generator.

use std::collections::HashMap;

use super::{Face, Mesh};
use crate::Point;

/// Unit icosphere: an icosahedron subdivided `level` times (each level splits
/// every triangle into four) with vertices projected onto the unit sphere.
/// Vertex count 10·4^level + 2 (level 5: 10 242).
pub fn icosphere(level: u32) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut vertices: Vec<Point> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Point::from(nalgebra::Vector3::new(x, y, z).normalize()))
    .collect();
    let mut faces: Vec<Face> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut midpoints: HashMap<(usize, usize), usize> = HashMap::new();
        let mut mid = |a: usize, b: usize, vs: &mut Vec<Point>| -> usize {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                let m = (vs[a].coords + vs[b].coords).normalize();
                vs.push(Point::from(m));
                vs.len() - 1
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for &[a, b, c] in &faces {
            let ab = mid(a, b, &mut vertices);
            let bc = mid(b, c, &mut vertices);
            let ca = mid(c, a, &mut vertices);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    Mesh::new(vertices, faces).expect("icosphere is valid by construction")
}

/// Torus around the z axis with major radius `major` and minor radius
/// `minor`, `nu` samples around the axis and `nv` around the tube (both ≥ 3).
pub fn torus(major: f64, minor: f64, nu: usize, nv: usize) -> Mesh {
    assert!(nu >= 3 && nv >= 3, "torus needs at least 3×3 samples");
    let mut vertices = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        let u = 2.0 * std::f64::consts::PI * i as f64 / nu as f64;
        for j in 0..nv {
            let v = 2.0 * std::f64::consts::PI * j as f64 / nv as f64;
            let r = major + minor * v.cos();
            vertices.push(Point::new(r * u.cos(), r * u.sin(), minor * v.sin()));
        }
    }
    let idx = |i: usize, j: usize| (i % nu) * nv + (j % nv);
    let mut faces = Vec::with_capacity(2 * nu * nv);
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    Mesh::new(vertices, faces).expect("torus is valid by construction")
}

/// Flat grid in the z = 0 plane over [0, 1]², `nx` × `ny` cells, each split
/// into two triangles along alternating diagonals.
pub fn grid(nx: usize, ny: usize) -> Mesh {
    assert!(nx >= 1 && ny >= 1, "grid needs at least one cell");
    let mut vertices = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            vertices.push(Point::new(i as f64 / nx as f64, j as f64 / ny as f64, 0.0));
        }
    }
    let idx = |i: usize, j: usize| j * (nx + 1) + i;
    let mut faces = Vec::with_capacity(2 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            if (i + j) % 2 == 0 {
                faces.push([a, b, c]);
                faces.push([a, c, d]);
            } else {
                faces.push([a, b, d]);
                faces.push([b, c, d]);
            }
        }
    }
    Mesh::new(vertices, faces).expect("grid is valid by construction")
}

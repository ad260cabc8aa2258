//! A remesh of a closed triangle mesh whose vertices lie exactly on the
//! original surface, with the map "remesh vertex → (face, barycentric)".
//!
//! Method: split every edge at its midpoint (1 → 4 triangles), then
//! decimate by half-edge collapses (vertices never move, so every surviving
//! vertex keeps its exact surface location) in seeded, length-ordered
//! passes, and finally flip edges between nearly coplanar triangles towards
//! the Delaunay condition. The result has a different vertex count, a
//! different sampling (mostly edge midpoints) and different connectivity.

use std::collections::HashMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::mesh::{Face, Mesh};
use crate::{Error, Point, Result, Vec3};

/// A point on a triangle mesh: face index and barycentric coordinates
/// (weights of the face's three corners, summing to 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub face: usize,
    pub bary: [f64; 3],
}

impl SurfacePoint {
    /// Position of the point on `mesh` (any pose of the same connectivity).
    pub fn eval(&self, mesh: &Mesh) -> Result<Point> {
        let f = mesh.faces().get(self.face).ok_or_else(|| {
            Error::invalid(format!(
                "surface point on face {}, but the mesh has {} faces",
                self.face,
                mesh.n_faces()
            ))
        })?;
        let v = mesh.vertices();
        Ok(Point::from(
            v[f[0]].coords * self.bary[0]
                + v[f[1]].coords * self.bary[1]
                + v[f[2]].coords * self.bary[2],
        ))
    }
}

/// A remeshed copy and its map onto the original connectivity.
#[derive(Clone, Debug)]
pub struct Remeshed {
    /// The remeshed surface (in the pose it was computed in).
    pub mesh: Mesh,
    /// For each remesh vertex, its location on the original mesh.
    pub map: Vec<SurfacePoint>,
}

impl Remeshed {
    /// The remesh in the pose of `original` (a mesh with the connectivity
    /// the map refers to): barycentric interpolation of its vertices.
    pub fn transfer(&self, original: &Mesh) -> Result<Mesh> {
        let v = self
            .map
            .iter()
            .map(|s| s.eval(original))
            .collect::<Result<Vec<_>>>()?;
        self.mesh.with_vertices(v)
    }
}

/// Remeshes the closed manifold `mesh` to about `keep · n_vertices`
/// vertices (`keep` in [0.3, 2]), seeded.
pub fn remesh(mesh: &Mesh, keep: f64, seed: u64) -> Result<Remeshed> {
    if !(0.3..=2.0).contains(&keep) {
        return Err(Error::invalid(format!(
            "remesh keep ratio {keep} not in [0.3, 2]"
        )));
    }
    let faces0 = mesh.faces();
    let v0 = mesh.vertices();
    // Midpoint split.
    let mut pos: Vec<Point> = v0.to_vec();
    let mut sp: Vec<SurfacePoint> = vec![
        SurfacePoint {
            face: usize::MAX,
            bary: [0.0; 3]
        };
        v0.len()
    ];
    for (fi, f) in faces0.iter().enumerate() {
        for (k, &vi) in f.iter().enumerate() {
            if sp[vi].face == usize::MAX {
                let mut bary = [0.0; 3];
                bary[k] = 1.0;
                sp[vi] = SurfacePoint { face: fi, bary };
            }
        }
    }
    if sp.iter().any(|s| s.face == usize::MAX) {
        return Err(Error::invalid("remesh: mesh has vertices in no face"));
    }
    let mut mids: HashMap<(usize, usize), usize> = HashMap::new();
    let mut faces: Vec<Face> = Vec::with_capacity(4 * faces0.len());
    for (fi, f) in faces0.iter().enumerate() {
        let mut m = [0usize; 3];
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            let key = (a.min(b), a.max(b));
            m[k] = *mids.entry(key).or_insert_with(|| {
                let mut bary = [0.0; 3];
                bary[k] = 0.5;
                bary[(k + 1) % 3] = 0.5;
                pos.push(Point::from((v0[a].coords + v0[b].coords) * 0.5));
                sp.push(SurfacePoint { face: fi, bary });
                pos.len() - 1
            });
        }
        faces.push([f[0], m[0], m[2]]);
        faces.push([f[1], m[1], m[0]]);
        faces.push([f[2], m[2], m[1]]);
        faces.push([m[0], m[1], m[2]]);
    }
    let target = ((keep * v0.len() as f64).round() as usize).max(4);
    let mut d = Decimator::new(pos, faces);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for pass in 0..40 {
        crate::solve::progress::update_with(
            || {
                format!(
                    "remeshing: {} → {target} vertices, collapse pass",
                    d.alive_vertices
                )
            },
            pass,
            0,
        );
        if d.alive_vertices <= target {
            break;
        }
        if d.pass(target, &mut rng) == 0 {
            break;
        }
    }
    for _ in 0..4 {
        if d.flip_pass() == 0 {
            break;
        }
    }
    // Compact.
    let mut new_index = vec![usize::MAX; d.pos.len()];
    let mut vertices = Vec::new();
    let mut map = Vec::new();
    for (i, &alive) in d.vert_alive.iter().enumerate() {
        if alive {
            new_index[i] = vertices.len();
            vertices.push(d.pos[i]);
            map.push(sp[i]);
        }
    }
    let faces: Vec<Face> = d
        .faces
        .iter()
        .zip(&d.face_alive)
        .filter(|(_, &a)| a)
        .map(|(f, _)| f.map(|v| new_index[v]))
        .collect();
    // Positions are recomputed from the map, so the map is exact by
    // construction (up to rounding in the barycentric combination).
    let out = Remeshed {
        mesh: Mesh::new(vertices, faces)?,
        map,
    };
    let exact = out.transfer(mesh)?;
    Ok(Remeshed {
        mesh: exact,
        map: out.map,
    })
}

struct Decimator {
    pos: Vec<Point>,
    faces: Vec<Face>,
    face_alive: Vec<bool>,
    vert_alive: Vec<bool>,
    vert_faces: Vec<Vec<usize>>,
    alive_vertices: usize,
}

fn normal(p: &[Point], f: &Face) -> Vec3 {
    (p[f[1]] - p[f[0]]).cross(&(p[f[2]] - p[f[0]]))
}

/// 2·area / longest edge² (0.866 for an equilateral triangle).
fn quality(p: &[Point], f: &Face) -> f64 {
    let n = normal(p, f).norm();
    let l = (0..3)
        .map(|k| (p[f[(k + 1) % 3]] - p[f[k]]).norm_squared())
        .fold(0.0, f64::max);
    if l > 0.0 {
        n / l
    } else {
        0.0
    }
}

impl Decimator {
    fn new(pos: Vec<Point>, faces: Vec<Face>) -> Self {
        let mut vert_faces = vec![Vec::new(); pos.len()];
        for (fi, f) in faces.iter().enumerate() {
            for &v in f {
                vert_faces[v].push(fi);
            }
        }
        let n = pos.len();
        Decimator {
            face_alive: vec![true; faces.len()],
            vert_alive: vec![true; n],
            alive_vertices: n,
            pos,
            faces,
            vert_faces,
        }
    }

    fn neighbours(&self, v: usize) -> Vec<usize> {
        let mut n: Vec<usize> = self.vert_faces[v]
            .iter()
            .flat_map(|&f| self.faces[f])
            .filter(|&x| x != v)
            .collect();
        n.sort_unstable();
        n.dedup();
        n
    }

    /// Collapses `u` into `v` if that keeps the mesh manifold and well
    /// shaped. Returns whether it did.
    fn try_collapse(&mut self, u: usize, v: usize) -> bool {
        let shared: Vec<usize> = self.vert_faces[u]
            .iter()
            .copied()
            .filter(|&f| self.faces[f].contains(&v))
            .collect();
        if shared.len() != 2 {
            return false;
        }
        let nu = self.neighbours(u);
        let nv = self.neighbours(v);
        let common = nu.iter().filter(|x| nv.binary_search(x).is_ok()).count();
        if common != 2 || nv.len() + nu.len() - 4 > 9 || nu.len() <= 3 {
            return false;
        }
        for &f in &self.vert_faces[u] {
            if shared.contains(&f) {
                continue;
            }
            let old = self.faces[f];
            let new = old.map(|x| if x == u { v } else { x });
            let (no, nn) = (normal(&self.pos, &old), normal(&self.pos, &new));
            if no.dot(&nn) <= 0.7 * no.norm() * nn.norm() || quality(&self.pos, &new) < 0.25 {
                return false;
            }
        }
        for &f in &shared {
            self.face_alive[f] = false;
        }
        let moved: Vec<usize> = self.vert_faces[u]
            .iter()
            .copied()
            .filter(|f| !shared.contains(f))
            .collect();
        for &f in &moved {
            for x in self.faces[f].iter_mut() {
                if *x == u {
                    *x = v;
                }
            }
        }
        self.vert_faces[v].retain(|f| !shared.contains(f));
        self.vert_faces[v].extend(moved);
        for &f in &shared {
            for x in self.faces[f] {
                if x != v && x != u {
                    self.vert_faces[x].retain(|g| *g != f);
                }
            }
        }
        self.vert_faces[u].clear();
        self.vert_alive[u] = false;
        self.alive_vertices -= 1;
        true
    }

    /// One pass over the edges, shortest first (with seeded jitter); each
    /// vertex takes part in at most one collapse per pass.
    fn pass(&mut self, target: usize, rng: &mut ChaCha8Rng) -> usize {
        let mut edges: Vec<(f64, usize, usize)> = Vec::new();
        for (fi, f) in self.faces.iter().enumerate() {
            if !self.face_alive[fi] {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if a < b {
                    let l = (self.pos[a] - self.pos[b]).norm();
                    edges.push((l * rng.random_range(1.0..1.3), a, b));
                }
            }
        }
        edges.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        let mut touched = vec![false; self.pos.len()];
        let mut done = 0;
        for (_, a, b) in edges {
            if self.alive_vertices <= target {
                break;
            }
            if touched[a] || touched[b] || !self.vert_alive[a] || !self.vert_alive[b] {
                continue;
            }
            let (u, v) = if rng.random_bool(0.5) { (a, b) } else { (b, a) };
            if self.try_collapse(u, v) || self.try_collapse(v, u) {
                for n in self.neighbours(a).into_iter().chain(self.neighbours(b)) {
                    touched[n] = true;
                }
                touched[a] = true;
                touched[b] = true;
                done += 1;
            }
        }
        done
    }

    /// Flips edges between nearly coplanar triangles when the opposite
    /// angles sum to more than π (Delaunay) and the flip improves quality.
    fn flip_pass(&mut self) -> usize {
        let mut edge_faces: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
        let mut order: Vec<(usize, usize)> = Vec::new();
        for (fi, f) in self.faces.iter().enumerate() {
            if !self.face_alive[fi] {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                let e = edge_faces.entry(key).or_default();
                if e.is_empty() {
                    order.push(key);
                }
                e.push(fi);
            }
        }
        let mut flipped = 0;
        let mut dirty = vec![false; self.faces.len()];
        for key in order {
            let fs = &edge_faces[&key];
            if fs.len() != 2 || dirty[fs[0]] || dirty[fs[1]] {
                continue;
            }
            let (f0, f1) = (fs[0], fs[1]);
            let (a, b) = key;
            // Orient: f0 holds a → b.
            let has_ab = |f: &Face| (0..3).any(|k| f[k] == a && f[(k + 1) % 3] == b);
            let (f0, f1) = if has_ab(&self.faces[f0]) {
                (f0, f1)
            } else {
                (f1, f0)
            };
            let c = self.faces[f0].iter().copied().find(|&x| x != a && x != b);
            let d = self.faces[f1].iter().copied().find(|&x| x != a && x != b);
            let (Some(c), Some(d)) = (c, d) else { continue };
            if c == d || self.neighbours(c).contains(&d) {
                continue;
            }
            let p = &self.pos;
            let (n0, n1) = (normal(p, &self.faces[f0]), normal(p, &self.faces[f1]));
            if n0.dot(&n1) < 0.985 * n0.norm() * n1.norm() {
                continue;
            }
            let angle = |x: usize, y: usize, z: usize| (p[y] - p[x]).angle(&(p[z] - p[x]));
            if angle(c, a, b) + angle(d, a, b) <= std::f64::consts::PI + 1e-9 {
                continue;
            }
            // f0 = (a, b, c) rotated, f1 = (b, a, d) rotated.
            let g0 = [c, a, d];
            let g1 = [d, b, c];
            let q_old = quality(p, &self.faces[f0]).min(quality(p, &self.faces[f1]));
            let q_new = quality(p, &g0).min(quality(p, &g1));
            let (m0, m1) = (normal(p, &g0), normal(p, &g1));
            if q_new <= q_old || m0.dot(&n0) <= 0.0 || m1.dot(&n0) <= 0.0 {
                continue;
            }
            self.faces[f0] = g0;
            self.faces[f1] = g1;
            self.vert_faces[a].retain(|&f| f != f1);
            self.vert_faces[b].retain(|&f| f != f0);
            self.vert_faces[c].push(f1);
            self.vert_faces[d].push(f0);
            dirty[f0] = true;
            dirty[f1] = true;
            flipped += 1;
        }
        flipped
    }
}

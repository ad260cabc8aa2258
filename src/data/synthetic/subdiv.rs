//! Catmull–Clark subdivision of a closed quad mesh, as linear stencils.
//!
//! The connectivity is computed once; the stencils then map any attribute of
//! the cage (positions, skinning weights) to the fine mesh, so every subject
//! shares the fine connectivity exactly.

use std::collections::HashMap;

/// Sparse rows: fine vertex `i` = Σ w · coarse[j] over `rows[i]`.
#[derive(Clone, Debug)]
pub struct Stencil {
    rows: Vec<Vec<(usize, f64)>>,
}

impl Stencil {
    /// Applies the stencil to per-vertex values of any linear type.
    pub fn apply<T>(&self, coarse: &[T]) -> Vec<T>
    where
        T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T> + Zero,
    {
        self.rows
            .iter()
            .map(|row| {
                row.iter()
                    .fold(T::zero(), |acc, &(j, w)| acc + coarse[j] * w)
            })
            .collect()
    }

    /// Number of fine vertices.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// True when there are no fine vertices.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }
}

/// Additive identity (local trait so arrays of weights can be subdivided).
pub trait Zero {
    fn zero() -> Self;
}

impl Zero for crate::Vec3 {
    fn zero() -> Self {
        crate::Vec3::zeros()
    }
}

/// Per-vertex skinning weights wrapped for linear combination.
#[derive(Clone, Copy, Debug)]
pub struct WeightVec(pub super::body::Weights);

impl Zero for WeightVec {
    fn zero() -> Self {
        WeightVec([0.0; super::body::N_BONES])
    }
}

impl std::ops::Add for WeightVec {
    type Output = Self;
    fn add(mut self, o: Self) -> Self {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a += b;
        }
        self
    }
}

impl std::ops::Mul<f64> for WeightVec {
    type Output = Self;
    fn mul(mut self, s: f64) -> Self {
        for a in self.0.iter_mut() {
            *a *= s;
        }
        self
    }
}

/// One Catmull–Clark step on a closed quad mesh with `n` vertices. Returns
/// the stencil and the fine quads. Fine vertices are ordered: vertex points
/// (`n`), edge points (edges in order of first appearance), face points.
pub fn catmull_clark(n: usize, quads: &[[usize; 4]]) -> (Stencil, Vec<[usize; 4]>) {
    let mut edge_index: HashMap<(usize, usize), usize> = HashMap::new();
    let mut edges: Vec<(usize, usize)> = Vec::new();
    let mut edge_faces: Vec<Vec<usize>> = Vec::new();
    let mut vert_faces: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut vert_edges: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (fi, q) in quads.iter().enumerate() {
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            let key = (a.min(b), a.max(b));
            let e = *edge_index.entry(key).or_insert_with(|| {
                edges.push(key);
                edge_faces.push(Vec::new());
                vert_edges[key.0].push(edges.len() - 1);
                vert_edges[key.1].push(edges.len() - 1);
                edges.len() - 1
            });
            edge_faces[e].push(fi);
            vert_faces[q[k]].push(fi);
        }
    }
    let face_row =
        |f: usize| -> Vec<(usize, f64)> { quads[f].iter().map(|&v| (v, 0.25)).collect() };
    let mut rows: Vec<Vec<(usize, f64)>> = Vec::with_capacity(n + edges.len() + quads.len());
    // Vertex points: (F + 2R + (k-3)P) / k.
    for v in 0..n {
        let k = vert_faces[v].len().max(1) as f64;
        let mut acc: Vec<(usize, f64)> = vec![(v, (k - 3.0) / k)];
        for &f in &vert_faces[v] {
            for (j, w) in face_row(f) {
                acc.push((j, w / (k * k)));
            }
        }
        for &e in &vert_edges[v] {
            let (a, b) = edges[e];
            acc.push((a, 1.0 / (k * k)));
            acc.push((b, 1.0 / (k * k)));
        }
        rows.push(compact(acc));
    }
    // Edge points: (a + b + f0 + f1) / 4.
    for (e, &(a, b)) in edges.iter().enumerate() {
        let mut acc = vec![(a, 0.25), (b, 0.25)];
        let nf = edge_faces[e].len().max(1) as f64;
        for &f in &edge_faces[e] {
            for (j, w) in face_row(f) {
                acc.push((j, w * 0.5 / nf));
            }
        }
        rows.push(compact(acc));
    }
    for f in 0..quads.len() {
        rows.push(face_row(f));
    }
    let base_e = n;
    let base_f = n + edges.len();
    let eidx = |a: usize, b: usize| base_e + edge_index[&(a.min(b), a.max(b))];
    let mut fine = Vec::with_capacity(4 * quads.len());
    for (fi, q) in quads.iter().enumerate() {
        let fp = base_f + fi;
        for k in 0..4 {
            let (p, nx, pv) = (q[k], q[(k + 1) % 4], q[(k + 3) % 4]);
            fine.push([p, eidx(p, nx), fp, eidx(pv, p)]);
        }
    }
    (Stencil { rows }, fine)
}

fn compact(mut acc: Vec<(usize, f64)>) -> Vec<(usize, f64)> {
    acc.sort_unstable_by_key(|e| e.0);
    let mut out: Vec<(usize, f64)> = Vec::with_capacity(acc.len());
    for (j, w) in acc {
        match out.last_mut() {
            Some((lj, lw)) if *lj == j => *lw += w,
            _ => out.push((j, w)),
        }
    }
    out
}

/// Composes two stencils: `second ∘ first`.
pub fn compose(first: &Stencil, second: &Stencil) -> Stencil {
    let rows = second
        .rows
        .iter()
        .map(|row| {
            let mut acc = Vec::new();
            for &(j, w) in row {
                for &(k, x) in &first.rows[j] {
                    acc.push((k, w * x));
                }
            }
            compact(acc)
        })
        .collect();
    Stencil { rows }
}

/// `levels` Catmull–Clark steps as one stencil plus the fine quads.
pub fn subdivide(n: usize, quads: &[[usize; 4]], levels: u32) -> (Stencil, Vec<[usize; 4]>) {
    let mut stencil = Stencil {
        rows: (0..n).map(|i| vec![(i, 1.0)]).collect(),
    };
    let mut quads = quads.to_vec();
    for _ in 0..levels {
        let (s, q) = catmull_clark(stencil.len(), &quads);
        stencil = compose(&stencil, &s);
        quads = q;
    }
    (stencil, quads)
}

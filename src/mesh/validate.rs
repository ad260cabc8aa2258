//! Defect report for one mesh.
//!
//! [`DefectReport::of`] works on a [`RawMesh`] (whatever a file said), so a
//! broken file can be described before it is refused; [`DefectReport::of_mesh`]
//! does the same for a validated [`Mesh`]. Every defect is counted, and the
//! first [`LIST_CAP`] offenders (in index order) are kept.
//!
//! Definitions used throughout:
//!
//! - A face is **out of range** when one of its indices is `≥` the vertex
//!   count. A face with **repeated indices** (e.g. `[4, 4, 9]`) is reported as
//!   such (and not also as zero-area). Both kinds are left out of everything
//!   topological below (edges, components, Euler characteristic, winding).
//! - A face is **zero-area** (degenerate) when its area `A` and longest edge
//!   `L` satisfy `A ≤ ZERO_AREA_RELATIVE · L²` (or `L = 0`): the test is
//!   relative to the face's own size, so it flags needles and caps whose
//!   smallest height is below ~`2·10⁻¹⁰ · L` independently of the mesh's
//!   scale. Faces touching a non-finite vertex are not tested.
//! - **Duplicate** faces use the same vertex set as an earlier face (in any
//!   order or winding); the later ones are listed.
//! - An undirected edge is a **boundary** edge when one face uses it,
//!   **non-manifold** when more than two do. An edge used by exactly two faces
//!   in the same direction is an **inconsistent-winding** edge.
//! - A vertex is **non-manifold** when its link (the edges opposite to it in
//!   its faces) is not a single path or cycle, i.e. its faces do not form one
//!   disk or half-disk. Vertices on non-manifold edges are therefore
//!   non-manifold too, as are "bow-tie" vertices where two fans touch.
//! - **Components** are sets of faces connected through shared vertices.
//! - The **Euler characteristic** is `V − E + F` over referenced vertices,
//!   distinct edges and faces (unreferenced vertices are not counted).
//! - **Genus** (per component) is reported only for manifold, orientable
//!   components: `g = (2 − χ − b) / 2` with `b` boundary loops. For a closed
//!   component that is the usual genus; for one with boundary it is the genus
//!   of the surface obtained by capping every boundary loop with a disk. For
//!   non-manifold or non-orientable components it is `None` (printed `—`).

use std::fmt;

use super::{Face, Mesh, RawMesh};
use crate::Point;

/// How many offending indices each list keeps.
pub const LIST_CAP: usize = 10;

/// A face is zero-area when `area ≤ ZERO_AREA_RELATIVE · (longest edge)²`.
/// For reference, an equilateral triangle has `area ≈ 0.433 · L²`.
pub const ZERO_AREA_RELATIVE: f64 = 1e-10;

/// A count of offenders and the first [`LIST_CAP`] of them, in index order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Offenders<T> {
    pub count: usize,
    pub first: Vec<T>,
}

impl<T> Default for Offenders<T> {
    fn default() -> Self {
        Offenders {
            count: 0,
            first: Vec::new(),
        }
    }
}

impl<T> Offenders<T> {
    fn push(&mut self, t: T) {
        self.count += 1;
        if self.first.len() < LIST_CAP {
            self.first.push(t);
        }
    }

    /// No offenders.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }
}

impl<T: Ord> Offenders<T> {
    fn from_unsorted(mut all: Vec<T>) -> Self {
        all.sort_unstable();
        let mut o = Offenders::default();
        for t in all {
            o.push(t);
        }
        o
    }
}

/// One connected component (faces connected through shared vertices).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Component {
    /// Index of the component's first face (components are listed in the
    /// order of their first face).
    pub first_face: usize,
    pub n_faces: usize,
    pub n_vertices: usize,
    pub n_edges: usize,
    /// `V − E + F` of the component.
    pub euler_characteristic: i64,
    pub boundary_edges: usize,
    /// Number of closed boundary curves (connected sets of boundary edges).
    pub boundary_loops: usize,
    /// No non-manifold edge or vertex.
    pub manifold: bool,
    /// Whether the faces can be wound consistently; `None` when not manifold.
    pub orientable: Option<bool>,
    /// Fewest faces whose winding must be reversed to make the component
    /// consistently wound; `None` when not manifold or not orientable.
    pub faces_to_flip: Option<usize>,
    /// `(2 − χ − b) / 2`, see the module docs; `None` when not manifold or
    /// not orientable.
    pub genus: Option<i64>,
}

/// Everything that can be wrong with a triangle mesh, counted.
#[derive(Clone, Debug, PartialEq)]
pub struct DefectReport {
    pub n_vertices: usize,
    pub n_faces: usize,
    /// Distinct undirected edges of the faces used for topology.
    pub n_edges: usize,
    pub out_of_range_faces: Offenders<usize>,
    pub non_finite_vertices: Offenders<usize>,
    pub repeated_index_faces: Offenders<usize>,
    pub zero_area_faces: Offenders<usize>,
    pub duplicate_faces: Offenders<usize>,
    pub unreferenced_vertices: Offenders<usize>,
    /// Edges `[i, j]` with `i < j`.
    pub boundary_edges: Offenders<[usize; 2]>,
    pub non_manifold_edges: Offenders<[usize; 2]>,
    pub non_manifold_vertices: Offenders<usize>,
    pub inconsistent_edges: Offenders<[usize; 2]>,
    pub components: Vec<Component>,
    /// `V − E + F` of the whole mesh (sum over components).
    pub euler_characteristic: i64,
}

impl DefectReport {
    /// Describes raw data as read from a file.
    pub fn of(raw: &RawMesh) -> DefectReport {
        analyse(&raw.vertices, &raw.faces)
    }

    /// Describes a validated mesh.
    pub fn of_mesh(mesh: &Mesh) -> DefectReport {
        analyse(mesh.vertices(), mesh.faces())
    }

    /// No defect at all: no bad index or coordinate, no degenerate,
    /// duplicate or repeated-index face, no unreferenced vertex, no boundary,
    /// every edge and vertex manifold, consistent winding. (A closed,
    /// consistently wound 2-manifold; several components are allowed.)
    pub fn is_clean(&self) -> bool {
        self.boundary_edges.is_empty() && self.is_clean_ignoring_boundary()
    }

    /// Like [`is_clean`](Self::is_clean) but open surfaces (boundary edges)
    /// are accepted.
    /// An empty mesh (no faces) is not clean.
    pub fn is_clean_ignoring_boundary(&self) -> bool {
        self.n_faces > 0
            && self.out_of_range_faces.is_empty()
            && self.non_finite_vertices.is_empty()
            && self.repeated_index_faces.is_empty()
            && self.zero_area_faces.is_empty()
            && self.duplicate_faces.is_empty()
            && self.unreferenced_vertices.is_empty()
            && self.non_manifold_edges.is_empty()
            && self.non_manifold_vertices.is_empty()
            && self.inconsistent_edges.is_empty()
            && self.components.iter().all(|c| c.orientable == Some(true))
    }

    /// Whether [`Mesh::new`] would accept the data (indices in range, finite
    /// coordinates, at least one face).
    pub fn is_loadable(&self) -> bool {
        self.out_of_range_faces.is_empty()
            && self.non_finite_vertices.is_empty()
            && self.n_faces > 0
    }

    /// One line: counts, χ, genus and the non-zero defect counts, e.g.
    /// `21887 v, 43814 f, 1 comp, χ 3, genus —: 14 duplicate faces, 5 boundary edges`.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} v, {} f, {} comp, χ {}, genus {}",
            self.n_vertices,
            self.n_faces,
            self.components.len(),
            self.euler_characteristic,
            self.genus().map_or("—".to_string(), |g| g.to_string())
        );
        let items = [
            (self.out_of_range_faces.count, "faces out of range"),
            (self.non_finite_vertices.count, "non-finite vertices"),
            (self.repeated_index_faces.count, "repeated-index faces"),
            (self.zero_area_faces.count, "zero-area faces"),
            (self.duplicate_faces.count, "duplicate faces"),
            (self.unreferenced_vertices.count, "unreferenced vertices"),
            (self.non_manifold_edges.count, "non-manifold edges"),
            (self.non_manifold_vertices.count, "non-manifold vertices"),
            (self.inconsistent_edges.count, "inconsistent-winding edges"),
        ];
        let defects: Vec<String> = items
            .iter()
            .filter(|(n, _)| *n > 0)
            .map(|(n, what)| format!("{n} {what}"))
            .collect();
        if self.n_faces == 0 {
            s.push_str(": empty (no faces)");
            if !defects.is_empty() {
                s.push_str(", ");
                s.push_str(&defects.join(", "));
            }
        } else if defects.is_empty() && self.is_clean_ignoring_boundary() {
            s.push_str(": ");
            s.push_str(self.status());
        } else if !defects.is_empty() {
            s.push_str(": ");
            s.push_str(&defects.join(", "));
        } else {
            s.push_str(": non-orientable component");
        }
        s
    }

    /// One word for the mesh: `empty (no faces)`, `clean` (a closed,
    /// consistently wound 2-manifold), `clean open surface` (the same with
    /// a boundary: valid input, the boundary is not a defect) or `has
    /// defects`.
    pub fn status(&self) -> &'static str {
        if self.n_faces == 0 {
            "empty (no faces)"
        } else if self.is_clean() {
            "clean"
        } else if self.is_clean_ignoring_boundary() {
            "clean open surface"
        } else {
            "has defects"
        }
    }

    /// Sum of the component genera, when every component has one.
    pub fn genus(&self) -> Option<i64> {
        self.components.iter().map(|c| c.genus).sum()
    }
}

/// A closed surface is *flattened* when every vertex lies within
/// `FLAT_RELATIVE × extent` of one plane (extent: half the bounding-box
/// diagonal): its two sides then fold onto each other, faces at the rim
/// collapse and the cotangent Laplacian is singular, so every method on it
/// fails, each in its own words. A flat open surface (a disk) is fine.
pub const FLAT_RELATIVE: f64 = 1e-6;

/// When the mesh has a closed component (no boundary edges in `report`,
/// the mesh's own [`DefectReport`]) and all its referenced vertices lie in
/// one plane ([`FLAT_RELATIVE`]): what it is, for a message.
pub fn flattened(mesh: &Mesh, report: &DefectReport) -> Option<String> {
    if !report.components.iter().any(|c| c.boundary_edges == 0) {
        return None;
    }
    let mut used = vec![false; mesh.n_vertices()];
    for f in mesh.faces() {
        for &v in f {
            used[v] = true;
        }
    }
    let points: Vec<Point> = mesh
        .vertices()
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(p, _)| *p)
        .collect();
    let extent = super::half_diagonal(&points);
    if points.len() < 4 || extent.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let n = points.len() as f64;
    let centre = points
        .iter()
        .fold(crate::Vec3::zeros(), |a, p| a + p.coords)
        / n;
    let mut cov = nalgebra::Matrix3::<f64>::zeros();
    for p in &points {
        let d = (p.coords - centre) / extent;
        cov += d * d.transpose();
    }
    let eig = nalgebra::SymmetricEigen::new(cov);
    let k = eig.eigenvalues.imin();
    let normal = eig.eigenvectors.column(k).into_owned();
    let thickness = points
        .iter()
        .map(|p| ((p.coords - centre).dot(&normal)).abs())
        .fold(0.0, f64::max);
    (thickness <= FLAT_RELATIVE * extent).then(|| {
        format!(
            "the mesh is flattened: it is a closed surface, yet every vertex lies within \
             {thickness:.1e} of one plane (its extent is {extent:.3e}), so its two sides fold \
             onto each other and its Laplacian is singular (a coordinate dropped or overwritten, \
             e.g. by a property declared twice?)"
        )
    })
}

/// Whether a face (indices in range) is zero-area: `area ≤
/// ZERO_AREA_RELATIVE · L²` with `L` its longest edge, or `L = 0`.
pub fn is_zero_area(vertices: &[Point], f: &Face) -> bool {
    let (pa, pb, pc) = (vertices[f[0]], vertices[f[1]], vertices[f[2]]);
    let area = 0.5 * (pb - pa).cross(&(pc - pa)).norm();
    let l2 = (pb - pa)
        .norm_squared()
        .max((pc - pb).norm_squared())
        .max((pa - pc).norm_squared());
    l2 == 0.0 || area <= ZERO_AREA_RELATIVE * l2
}

/// Union–find with path halving.
struct Dsu(Vec<usize>);

impl Dsu {
    fn new(n: usize) -> Self {
        Dsu((0..n).collect())
    }
    fn find(&mut self, mut x: usize) -> usize {
        while self.0[x] != x {
            self.0[x] = self.0[self.0[x]];
            x = self.0[x];
        }
        x
    }
    fn union(&mut self, a: usize, b: usize) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.0[a.max(b)] = a.min(b);
        }
    }
}

fn analyse(vertices: &[Point], faces: &[Face]) -> DefectReport {
    let nv = vertices.len();
    let nf = faces.len();

    // Per-vertex and per-face checks.
    let mut non_finite_vertices = Offenders::default();
    let finite: Vec<bool> = vertices
        .iter()
        .map(|p| p.x.is_finite() && p.y.is_finite() && p.z.is_finite())
        .collect();
    for (i, &ok) in finite.iter().enumerate() {
        if !ok {
            non_finite_vertices.push(i);
        }
    }
    let mut out_of_range_faces = Offenders::default();
    let mut repeated_index_faces = Offenders::default();
    let mut zero_area_faces = Offenders::default();
    let mut referenced = vec![false; nv];
    // Faces used for topology: in range, three distinct indices.
    let mut topo: Vec<usize> = Vec::with_capacity(nf);
    for (fi, f) in faces.iter().enumerate() {
        if f.iter().any(|&v| v >= nv) {
            out_of_range_faces.push(fi);
            continue;
        }
        for &v in f {
            referenced[v] = true;
        }
        let [a, b, c] = *f;
        if a == b || b == c || c == a {
            repeated_index_faces.push(fi);
            continue;
        }
        topo.push(fi);
        if finite[a] && finite[b] && finite[c] && is_zero_area(vertices, f) {
            zero_area_faces.push(fi);
        }
    }
    let mut unreferenced_vertices = Offenders::default();
    for (i, &r) in referenced.iter().enumerate() {
        if !r {
            unreferenced_vertices.push(i);
        }
    }

    // Duplicate faces (same vertex set), among in-range faces.
    let mut keyed: Vec<([usize; 3], usize)> = faces
        .iter()
        .enumerate()
        .filter(|(_, f)| f.iter().all(|&v| v < nv))
        .map(|(i, f)| {
            let mut k = *f;
            k.sort_unstable();
            (k, i)
        })
        .collect();
    keyed.sort_unstable();
    let dups: Vec<usize> = keyed
        .windows(2)
        .filter(|w| w[0].0 == w[1].0)
        .map(|w| w[1].1)
        .collect();
    let duplicate_faces = Offenders::from_unsorted(dups);

    // Half-edges of topology faces, grouped by undirected edge.
    // (lo, hi, forward?, face)
    let mut half: Vec<(usize, usize, bool, usize)> = Vec::with_capacity(3 * topo.len());
    for &fi in &topo {
        let [a, b, c] = faces[fi];
        for (u, v) in [(a, b), (b, c), (c, a)] {
            half.push((u.min(v), u.max(v), u < v, fi));
        }
    }
    half.sort_unstable();
    let mut boundary = Vec::new();
    let mut non_manifold = Vec::new();
    let mut inconsistent = Vec::new();
    // Face adjacency across manifold edges: (f, g, same_direction).
    let mut adjacency: Vec<(usize, usize, bool)> = Vec::new();
    // One entry per distinct edge: (lo, hi, uses).
    let mut edges: Vec<(usize, usize, usize)> = Vec::new();
    let mut s = 0;
    while s < half.len() {
        let (lo, hi) = (half[s].0, half[s].1);
        let mut e = s;
        while e < half.len() && half[e].0 == lo && half[e].1 == hi {
            e += 1;
        }
        let uses = e - s;
        edges.push((lo, hi, uses));
        match uses {
            1 => boundary.push([lo, hi]),
            2 => {
                let same = half[s].2 == half[s + 1].2;
                if same {
                    inconsistent.push([lo, hi]);
                }
                adjacency.push((half[s].3, half[s + 1].3, same));
            }
            _ => non_manifold.push([lo, hi]),
        }
        s = e;
    }

    // Non-manifold vertices: link of each vertex must be one path or cycle.
    let mut start = vec![0usize; nv + 1];
    for &fi in &topo {
        for &v in &faces[fi] {
            start[v + 1] += 1;
        }
    }
    for i in 0..nv {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut incident = vec![0usize; start[nv]];
    for &fi in &topo {
        for &v in &faces[fi] {
            incident[fill[v]] = fi;
            fill[v] += 1;
        }
    }
    let mut nm_vertices = Vec::new();
    let mut link: Vec<(usize, usize)> = Vec::new();
    let mut ends: Vec<usize> = Vec::new();
    for v in 0..nv {
        let inc = &incident[start[v]..start[v + 1]];
        if inc.is_empty() {
            continue;
        }
        link.clear();
        for &fi in inc {
            let [a, b, c] = faces[fi];
            link.push(if v == a {
                (b, c)
            } else if v == b {
                (c, a)
            } else {
                (a, b)
            });
        }
        if !link_is_path_or_cycle(&link, &mut ends) {
            nm_vertices.push(v);
        }
    }

    // Components through shared vertices.
    let mut dsu = Dsu::new(nv);
    for &fi in &topo {
        let [a, b, c] = faces[fi];
        dsu.union(a, b);
        dsu.union(a, c);
    }
    let mut comp_of_root = vec![usize::MAX; nv];
    let mut components: Vec<Component> = Vec::new();
    let mut face_comp = vec![usize::MAX; nf];
    for &fi in &topo {
        let r = dsu.find(faces[fi][0]);
        if comp_of_root[r] == usize::MAX {
            comp_of_root[r] = components.len();
            components.push(Component {
                first_face: fi,
                n_faces: 0,
                n_vertices: 0,
                n_edges: 0,
                euler_characteristic: 0,
                boundary_edges: 0,
                boundary_loops: 0,
                manifold: true,
                orientable: None,
                faces_to_flip: None,
                genus: None,
            });
        }
        let c = comp_of_root[r];
        face_comp[fi] = c;
        components[c].n_faces += 1;
    }
    let mut vcomp = vec![usize::MAX; nv];
    for v in 0..nv {
        if start[v + 1] > start[v] {
            let c = comp_of_root[dsu.find(v)];
            vcomp[v] = c;
            components[c].n_vertices += 1;
        }
    }
    for &(lo, _, uses) in &edges {
        let c = &mut components[vcomp[lo]];
        c.n_edges += 1;
        if uses == 1 {
            c.boundary_edges += 1;
        } else if uses > 2 {
            c.manifold = false;
        }
    }
    for &v in &nm_vertices {
        components[vcomp[v]].manifold = false;
    }
    // Boundary loops: connected sets of boundary edges.
    let mut bdsu = Dsu::new(nv);
    for &[a, b] in &boundary {
        bdsu.union(a, b);
    }
    let mut counted = vec![false; nv];
    for &[a, b] in &boundary {
        for v in [a, b] {
            let r = bdsu.find(v);
            if !counted[r] {
                counted[r] = true;
                components[vcomp[v]].boundary_loops += 1;
            }
        }
    }
    // Orientation: propagate across manifold edges; a conflict means the
    // component cannot be wound consistently.
    let mut adj_start = vec![0usize; nf + 1];
    for &(f, g, _) in &adjacency {
        adj_start[f + 1] += 1;
        adj_start[g + 1] += 1;
    }
    for i in 0..nf {
        adj_start[i + 1] += adj_start[i];
    }
    let mut adj_fill = adj_start.clone();
    let mut adj = vec![(0usize, false); adj_start[nf]];
    for &(f, g, same) in &adjacency {
        adj[adj_fill[f]] = (g, same);
        adj_fill[f] += 1;
        adj[adj_fill[g]] = (f, same);
        adj_fill[g] += 1;
    }
    let mut flip: Vec<Option<bool>> = vec![None; nf];
    let mut conflict = vec![false; components.len()];
    let mut to_flip = vec![0usize; components.len()];
    let mut stack = Vec::new();
    for &seed in &topo {
        if flip[seed].is_some() {
            continue;
        }
        flip[seed] = Some(false);
        stack.push(seed);
        let (mut n, mut flipped) = (0usize, 0usize);
        while let Some(f) = stack.pop() {
            let ff = flip[f].unwrap_or(false);
            n += 1;
            flipped += usize::from(ff);
            for &(g, same) in &adj[adj_start[f]..adj_start[f + 1]] {
                // Same direction on a shared edge: exactly one must flip.
                let want = ff ^ same;
                match flip[g] {
                    None => {
                        flip[g] = Some(want);
                        stack.push(g);
                    }
                    Some(x) if x != want => conflict[face_comp[f]] = true,
                    _ => {}
                }
            }
        }
        to_flip[face_comp[seed]] += flipped.min(n - flipped);
    }
    for (ci, c) in components.iter_mut().enumerate() {
        c.euler_characteristic = c.n_vertices as i64 - c.n_edges as i64 + c.n_faces as i64;
        if c.manifold {
            c.orientable = Some(!conflict[ci]);
            if !conflict[ci] {
                c.faces_to_flip = Some(to_flip[ci]);
                let twice = 2 - c.euler_characteristic - c.boundary_loops as i64;
                if twice >= 0 && twice % 2 == 0 {
                    c.genus = Some(twice / 2);
                }
            }
        }
    }
    let euler_characteristic = components.iter().map(|c| c.euler_characteristic).sum();

    DefectReport {
        n_vertices: nv,
        n_faces: nf,
        n_edges: edges.len(),
        out_of_range_faces,
        non_finite_vertices,
        repeated_index_faces,
        zero_area_faces,
        duplicate_faces,
        unreferenced_vertices,
        boundary_edges: Offenders::from_unsorted(boundary),
        non_manifold_edges: Offenders::from_unsorted(non_manifold),
        non_manifold_vertices: Offenders::from_unsorted(nm_vertices),
        inconsistent_edges: Offenders::from_unsorted(inconsistent),
        components,
        euler_characteristic,
    }
}

/// Whether the graph with edges `link` is connected with every node of
/// degree ≤ 2 (a single path or cycle). `ends` is scratch space.
fn link_is_path_or_cycle(link: &[(usize, usize)], ends: &mut Vec<usize>) -> bool {
    ends.clear();
    for &(a, b) in link {
        ends.push(a);
        ends.push(b);
    }
    ends.sort_unstable();
    // Degrees: runs in the sorted endpoint list.
    let mut i = 0;
    while i < ends.len() {
        let mut j = i;
        while j < ends.len() && ends[j] == ends[i] {
            j += 1;
        }
        if j - i > 2 {
            return false;
        }
        i = j;
    }
    ends.dedup();
    let mut dsu = Dsu::new(ends.len());
    let pos = |x: usize| ends.binary_search(&x).unwrap_or(0);
    let mut parts = ends.len();
    for &(a, b) in link {
        let (ra, rb) = (dsu.find(pos(a)), dsu.find(pos(b)));
        if ra != rb {
            dsu.union(ra, rb);
            parts -= 1;
        }
    }
    parts == 1
}

fn fmt_list<T>(o: &Offenders<T>, item: impl Fn(&T) -> String) -> String {
    if o.count == 0 {
        return String::new();
    }
    let mut s: Vec<String> = o.first.iter().map(item).collect();
    if o.count > o.first.len() {
        s.push("…".into());
    }
    s.join(" ")
}

impl fmt::Display for DefectReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} vertices, {} faces, {} edges, {} component{}, Euler characteristic {}, genus {}; {}",
            self.n_vertices,
            self.n_faces,
            self.n_edges,
            self.components.len(),
            if self.components.len() == 1 { "" } else { "s" },
            self.euler_characteristic,
            self.genus().map_or("—".to_string(), |g| g.to_string()),
            self.status()
        )?;
        let idx = |i: &usize| i.to_string();
        let edge = |e: &[usize; 2]| format!("{}-{}", e[0], e[1]);
        let rows = [
            (
                "faces with index out of range",
                self.out_of_range_faces.count,
                fmt_list(&self.out_of_range_faces, idx),
            ),
            (
                "vertices with NaN/inf",
                self.non_finite_vertices.count,
                fmt_list(&self.non_finite_vertices, idx),
            ),
            (
                "faces with repeated vertex",
                self.repeated_index_faces.count,
                fmt_list(&self.repeated_index_faces, idx),
            ),
            (
                "zero-area faces",
                self.zero_area_faces.count,
                fmt_list(&self.zero_area_faces, idx),
            ),
            (
                "duplicate faces",
                self.duplicate_faces.count,
                fmt_list(&self.duplicate_faces, idx),
            ),
            (
                "unreferenced vertices",
                self.unreferenced_vertices.count,
                fmt_list(&self.unreferenced_vertices, idx),
            ),
            (
                "non-manifold edges",
                self.non_manifold_edges.count,
                fmt_list(&self.non_manifold_edges, edge),
            ),
            (
                "non-manifold vertices",
                self.non_manifold_vertices.count,
                fmt_list(&self.non_manifold_vertices, idx),
            ),
            (
                "inconsistent winding edges",
                self.inconsistent_edges.count,
                fmt_list(&self.inconsistent_edges, edge),
            ),
        ];
        writeln!(f, "  {:<30} {:>8}  first offenders", "defect", "count")?;
        for (name, count, list) in rows {
            writeln!(f, "  {name:<30} {count:>8}  {list}")?;
        }
        // An open surface is valid input: its boundary is reported as such,
        // not among the defects.
        let loops: usize = self.components.iter().map(|c| c.boundary_loops).sum();
        writeln!(
            f,
            "  boundary (not a defect): {} edges in {loops} loop{}  {}",
            self.boundary_edges.count,
            if loops == 1 { "" } else { "s" },
            fmt_list(&self.boundary_edges, edge)
        )?;
        writeln!(
            f,
            "  {:>4} {:>8} {:>8} {:>8} {:>6} {:>6} {:>8} {:>10} {:>6} {:>5}",
            "comp",
            "faces",
            "vertices",
            "edges",
            "χ",
            "loops",
            "manifold",
            "orientable",
            "flip",
            "genus"
        )?;
        let opt = |o: Option<String>| o.unwrap_or_else(|| "—".into());
        for (i, c) in self.components.iter().enumerate().take(LIST_CAP) {
            writeln!(
                f,
                "  {:>4} {:>8} {:>8} {:>8} {:>6} {:>6} {:>8} {:>10} {:>6} {:>5}",
                i,
                c.n_faces,
                c.n_vertices,
                c.n_edges,
                c.euler_characteristic,
                c.boundary_loops,
                if c.manifold { "yes" } else { "no" },
                opt(c
                    .orientable
                    .map(|o| if o { "yes".into() } else { "no".into() })),
                opt(c.faces_to_flip.map(|n| n.to_string())),
                opt(c.genus.map(|g| g.to_string())),
            )?;
        }
        if self.components.len() > LIST_CAP {
            writeln!(
                f,
                "  … {} more components",
                self.components.len() - LIST_CAP
            )?;
        }
        Ok(())
    }
}

/// A defect that changes what the methods compute on a mesh, so `run`,
/// `transfer` and `keypoints` warn about it (or refuse the mesh in strict
/// mode). Boundary edges are not among them: open surfaces are valid input.
/// Out-of-range indices and non-finite coordinates are not either: such a
/// file is refused when it is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum DefectKind {
    DuplicateFaces,
    ZeroAreaFaces,
    RepeatedIndexFaces,
    NonManifoldEdges,
    NonManifoldVertices,
    /// Edges used twice in one direction, or a component that cannot be
    /// wound consistently.
    InconsistentOrientation,
    SeveralComponents,
    UnreferencedVertices,
}

impl DefectKind {
    /// Every kind, in report order.
    pub const ALL: [DefectKind; 8] = [
        DefectKind::DuplicateFaces,
        DefectKind::ZeroAreaFaces,
        DefectKind::RepeatedIndexFaces,
        DefectKind::NonManifoldEdges,
        DefectKind::NonManifoldVertices,
        DefectKind::InconsistentOrientation,
        DefectKind::SeveralComponents,
        DefectKind::UnreferencedVertices,
    ];

    /// Stable snake-case name (manifests, logs).
    pub fn name(self) -> &'static str {
        match self {
            DefectKind::DuplicateFaces => "duplicate_faces",
            DefectKind::ZeroAreaFaces => "zero_area_faces",
            DefectKind::RepeatedIndexFaces => "repeated_index_faces",
            DefectKind::NonManifoldEdges => "non_manifold_edges",
            DefectKind::NonManifoldVertices => "non_manifold_vertices",
            DefectKind::InconsistentOrientation => "inconsistent_orientation",
            DefectKind::SeveralComponents => "several_components",
            DefectKind::UnreferencedVertices => "unreferenced_vertices",
        }
    }
}

/// One kind of result-changing defect found in a mesh: how many offenders
/// and the first few, e.g. `14 duplicate faces (first: 43800 43801 …)`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Defect {
    pub kind: DefectKind,
    pub count: usize,
    /// The counted thing and the first offenders, ready to print
    /// (`duplicate faces (first: 3 17)`).
    pub detail: String,
}

impl fmt::Display for Defect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.count, self.detail)
    }
}

impl DefectReport {
    /// The defects that change results ([`DefectKind`]), one entry per
    /// kind present, in [`DefectKind::ALL`] order. Empty for a clean mesh
    /// (an open but otherwise clean surface included).
    pub fn result_defects(&self) -> Vec<Defect> {
        let idx = |i: &usize| i.to_string();
        let edge = |e: &[usize; 2]| format!("{}-{}", e[0], e[1]);
        let listed = |what: &str, list: String| format!("{what} (first: {list})");
        let mut out = Vec::new();
        for kind in DefectKind::ALL {
            let (count, detail) = match kind {
                DefectKind::DuplicateFaces => (
                    self.duplicate_faces.count,
                    listed("duplicate faces", fmt_list(&self.duplicate_faces, idx)),
                ),
                DefectKind::ZeroAreaFaces => (
                    self.zero_area_faces.count,
                    listed("zero-area faces", fmt_list(&self.zero_area_faces, idx)),
                ),
                DefectKind::RepeatedIndexFaces => (
                    self.repeated_index_faces.count,
                    listed(
                        "faces with a repeated vertex",
                        fmt_list(&self.repeated_index_faces, idx),
                    ),
                ),
                DefectKind::NonManifoldEdges => (
                    self.non_manifold_edges.count,
                    listed(
                        "non-manifold edges",
                        fmt_list(&self.non_manifold_edges, edge),
                    ),
                ),
                DefectKind::NonManifoldVertices => (
                    self.non_manifold_vertices.count,
                    listed(
                        "non-manifold vertices",
                        fmt_list(&self.non_manifold_vertices, idx),
                    ),
                ),
                DefectKind::InconsistentOrientation => {
                    let non_orientable = self
                        .components
                        .iter()
                        .filter(|c| c.orientable == Some(false))
                        .count();
                    let to_flip: usize =
                        self.components.iter().filter_map(|c| c.faces_to_flip).sum();
                    if self.inconsistent_edges.is_empty() && non_orientable == 0 {
                        (0, String::new())
                    } else {
                        let mut what = "inconsistent-winding edges".to_string();
                        if to_flip > 0 {
                            what.push_str(&format!(", {to_flip} faces wound against the rest"));
                        }
                        if non_orientable > 0 {
                            what.push_str(&format!(
                                ", {non_orientable} non-orientable component(s)"
                            ));
                        }
                        (
                            self.inconsistent_edges.count,
                            listed(&what, fmt_list(&self.inconsistent_edges, edge)),
                        )
                    }
                }
                DefectKind::SeveralComponents => {
                    let n = self.components.len();
                    if n < 2 {
                        (0, String::new())
                    } else {
                        let mut sizes: Vec<String> = self
                            .components
                            .iter()
                            .take(LIST_CAP)
                            .map(|c| c.n_faces.to_string())
                            .collect();
                        if n > LIST_CAP {
                            sizes.push("…".into());
                        }
                        (n, format!("components (faces: {})", sizes.join(" ")))
                    }
                }
                DefectKind::UnreferencedVertices => (
                    self.unreferenced_vertices.count,
                    listed(
                        "unreferenced vertices",
                        fmt_list(&self.unreferenced_vertices, idx),
                    ),
                ),
            };
            if count > 0 {
                out.push(Defect {
                    kind,
                    count,
                    detail,
                });
            }
        }
        out
    }
}

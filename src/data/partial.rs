//! Partial shapes for the shape completion and registration experiment
//! (FBT Sec. 5): from a full mesh, remove regions (planar cuts and
//! geodesic holes) so that more than half of the area remains, in a few
//! parts, while never removing a vertex within a geodesic radius of
//! `protect_radius · √area` of any feature point. The map from partial to
//! full vertex indices is kept for evaluation.
//!
//! **Protection.** Distances are Dijkstra edge-path lengths, which
//! overestimate surface geodesics by up to ≈ 24 % (see
//! [`crate::ops::geodesic`]); to be safe every vertex with Dijkstra
//! distance ≤ 1.25 × the radius is protected, and so is the 1-ring around
//! them (a face is kept only if none of its vertices was removed, so the
//! ring keeps the protected vertices inside intact faces).
//!
//! **Removal.** First `cuts` slabs of width `cut_width · √A` across random
//! planes (normal uniform on the sphere, through a random unprotected
//! vertex), then geodesic balls of radius uniform in `hole_radius · √A`
//! around random unprotected vertices, until the kept area drops below the
//! target fraction (uniform in `keep_fraction`) or `max_attempts` removals
//! were tried. A removal that would leave no more than
//! `min_fraction + 0.01` of the area is skipped. Components of fewer than
//! `min_component_faces` faces are dropped at the end. Every random choice
//! comes from a ChaCha8 generator seeded by `seed`.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::mesh::{Face, Mesh};
use crate::ops::Operators;
use crate::ops::{dijkstra_distances, face_areas, farthest_point_sampling, FpsMetric};
use crate::{Error, Result, Vec3};

/// Options of [`make_partial`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartialOptions {
    /// Range of the target kept-area fraction.
    pub keep_fraction: (f64, f64),
    /// The kept area always exceeds this fraction (the paper: 50 %).
    pub min_fraction: f64,
    /// Protected geodesic radius around features, relative to √area
    /// (the paper: 15 %).
    pub protect_radius: f64,
    /// Number of planar cuts.
    pub cuts: usize,
    /// Slab width of a cut, relative to √area.
    pub cut_width: f64,
    /// Range of hole radii, relative to √area.
    pub hole_radius: (f64, f64),
    /// Removals tried at most.
    pub max_attempts: usize,
    /// Smaller components are dropped.
    pub min_component_faces: usize,
    pub seed: u64,
}

impl Default for PartialOptions {
    fn default() -> Self {
        PartialOptions {
            keep_fraction: (0.6, 0.8),
            min_fraction: 0.5,
            protect_radius: 0.15,
            cuts: 2,
            cut_width: 0.04,
            hole_radius: (0.08, 0.2),
            max_attempts: 40,
            min_component_faces: 20,
            seed: 0,
        }
    }
}

/// A partial shape and its relation to the full one.
#[derive(Clone, Debug)]
pub struct PartialShape {
    /// The partial mesh.
    pub mesh: Mesh,
    /// `vertex_map[i]` = index in the full mesh of partial vertex `i`
    /// (increasing).
    pub vertex_map: Vec<usize>,
    /// Feature points as indices into the partial mesh.
    pub features: Vec<usize>,
    /// The same in the full mesh.
    pub features_full: Vec<usize>,
    /// Kept area / full area.
    pub area_fraction: f64,
    /// Connected components (by shared vertices) of the partial mesh.
    pub n_components: usize,
    /// Removals applied (cuts and holes).
    pub removals: usize,
}

/// `k` feature points by geodesic (Dijkstra) farthest point sampling from a
/// seeded first vertex.
pub fn feature_points(mesh: &Mesh, k: usize, seed: u64) -> Result<Vec<usize>> {
    farthest_point_sampling(mesh, k, FpsMetric::Geodesic, seed)
}

/// Makes a partial shape (see the module docs). Errors on bad options,
/// features out of range, or when the protected regions alone cannot keep
/// the constraints (never in practice).
pub fn make_partial(
    full: &Mesh,
    features: &[usize],
    opts: &PartialOptions,
) -> Result<PartialShape> {
    let n = full.n_vertices();
    let (lo, hi) = opts.keep_fraction;
    if !(opts.min_fraction >= 0.0 && opts.min_fraction < lo && lo <= hi && hi <= 1.0) {
        return Err(Error::invalid(format!(
            "partial shape: need 0 ≤ min_fraction < keep_fraction.0 ≤ keep_fraction.1 ≤ 1, got {} and {:?}",
            opts.min_fraction, opts.keep_fraction
        )));
    }
    if !(opts.protect_radius >= 0.0
        && opts.cut_width > 0.0
        && opts.hole_radius.0 > 0.0
        && opts.hole_radius.0 <= opts.hole_radius.1)
    {
        return Err(Error::invalid(
            "partial shape: radii and widths must be positive",
        ));
    }
    if let Some(&f) = features.iter().find(|&&f| f >= n) {
        return Err(Error::invalid(format!(
            "feature vertex {f} out of range ({n} vertices)"
        )));
    }
    let fa = face_areas(full);
    let total: f64 = fa.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return Err(Error::invalid("partial shape: the mesh has no area"));
    }
    let s = total.sqrt();
    let nb = full.neighbours();
    let mut protected = vec![false; n];
    if !features.is_empty() {
        let d = dijkstra_distances(full, features)?;
        let r = 1.25 * opts.protect_radius * s;
        for i in 0..n {
            if d[i] <= r {
                protected[i] = true;
            }
        }
        let core = protected.clone();
        for (i, _) in core.iter().enumerate().filter(|(_, &c)| c) {
            for &j in nb.row(i) {
                protected[j] = true;
            }
        }
    }
    let faces = full.faces();
    let kept_area = |removed: &[bool]| -> f64 {
        faces
            .iter()
            .zip(&fa)
            .filter(|(f, _)| f.iter().all(|&v| !removed[v]))
            .map(|(_, a)| a)
            .sum()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let target = lo + (hi - lo) * rng.random::<f64>();
    let floor = (opts.min_fraction + 0.01) * total;
    let mut removed = vec![false; n];
    let free: Vec<usize> = (0..n).filter(|&i| !protected[i]).collect();
    let mut removals = 0;
    if !free.is_empty() {
        let v = full.vertices();
        for attempt in 0..opts.max_attempts {
            if kept_area(&removed) <= target * total {
                break;
            }
            let c = free[rng.random_range(0..free.len())];
            let set: Vec<usize> = if attempt < opts.cuts {
                let z: f64 = 2.0 * rng.random::<f64>() - 1.0;
                let phi = std::f64::consts::TAU * rng.random::<f64>();
                let rxy = (1.0 - z * z).max(0.0).sqrt();
                let normal = Vec3::new(rxy * phi.cos(), rxy * phi.sin(), z);
                let half = 0.5 * opts.cut_width * s;
                (0..n)
                    .filter(|&i| !protected[i] && normal.dot(&(v[i] - v[c])).abs() < half)
                    .collect()
            } else {
                let (a, b) = opts.hole_radius;
                let radius = (a + (b - a) * rng.random::<f64>()) * s;
                let d = dijkstra_distances(full, &[c])?;
                (0..n)
                    .filter(|&i| !protected[i] && d[i] <= radius)
                    .collect()
            };
            let mut trial = removed.clone();
            for &i in &set {
                trial[i] = true;
            }
            if kept_area(&trial) > floor {
                removed = trial;
                removals += 1;
            }
        }
    }
    // Kept faces, then drop tiny components.
    let mut kept: Vec<usize> = (0..faces.len())
        .filter(|&f| faces[f].iter().all(|&v| !removed[v]))
        .collect();
    let comp = face_components(faces, &kept, n);
    let n_comp = comp.iter().max().map_or(0, |m| m + 1);
    let mut size = vec![0usize; n_comp];
    for &c in &comp {
        size[c] += 1;
    }
    let is_feature_comp: Vec<bool> = {
        let mut v = vec![false; n_comp];
        for (k, &f) in kept.iter().enumerate() {
            if faces[f].iter().any(|x| features.contains(x)) {
                v[comp[k]] = true;
            }
        }
        v
    };
    let keep_comp: Vec<bool> = (0..n_comp)
        .map(|c| size[c] >= opts.min_component_faces || is_feature_comp[c])
        .collect();
    kept = kept
        .iter()
        .zip(&comp)
        .filter(|(_, &c)| keep_comp[c])
        .map(|(&f, _)| f)
        .collect();
    let n_components = keep_comp.iter().filter(|&&k| k).count();
    let mut used = vec![false; n];
    for &f in &kept {
        for &v in &faces[f] {
            used[v] = true;
        }
    }
    let vertex_map: Vec<usize> = (0..n).filter(|&i| used[i]).collect();
    let mut new_index = vec![usize::MAX; n];
    for (k, &i) in vertex_map.iter().enumerate() {
        new_index[i] = k;
    }
    let new_faces: Vec<Face> = kept
        .iter()
        .map(|&f| faces[f].map(|v| new_index[v]))
        .collect();
    let verts = vertex_map.iter().map(|&i| full.vertices()[i]).collect();
    let mesh = Mesh::new(verts, new_faces)?;
    let area: f64 = kept.iter().map(|&f| fa[f]).sum();
    let mut pf = Vec::with_capacity(features.len());
    for &f in features {
        if new_index[f] == usize::MAX {
            return Err(Error::numerical(format!(
                "feature vertex {f} was lost although protected"
            )));
        }
        pf.push(new_index[f]);
    }
    Ok(PartialShape {
        mesh,
        vertex_map,
        features: pf,
        features_full: features.to_vec(),
        area_fraction: area / total,
        n_components,
        removals,
    })
}

/// Component label (0..) of each kept face, faces connected through shared
/// vertices (union–find), labels in order of first appearance.
fn face_components(faces: &[Face], kept: &[usize], n: usize) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for &f in kept {
        let [a, b, c] = faces[f];
        for (x, y) in [(a, b), (b, c)] {
            let (rx, ry) = (find(&mut parent, x), find(&mut parent, y));
            if rx != ry {
                parent[rx.max(ry)] = rx.min(ry);
            }
        }
    }
    let mut label = vec![usize::MAX; n];
    let mut next = 0;
    kept.iter()
        .map(|&f| {
            let r = find(&mut parent, faces[f][0]);
            if label[r] == usize::MAX {
                label[r] = next;
                next += 1;
            }
            label[r]
        })
        .collect()
}

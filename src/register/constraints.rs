//! Constraint matrices `H` and targets `Y` (FBT Sec. 4.1: "simply the
//! coordinates of points on the mesh … or a weighted average of some vertex
//! positions"), and the feature-point constraints of the shape completion
//! experiment (Sec. 5): Voronoi-area-weighted averages of the vertices in
//! 10 geodesic circles around each feature point.

use nalgebra::DMatrix;

use super::solver::ConstraintRows;
use crate::mesh::Mesh;
use crate::ops::Operators;
use crate::ops::{dijkstra_distances, MassKind};
use crate::{Error, Point, Result};

/// Rows selecting single vertices: `H = e_i` per index.
pub fn vertex_rows(vertices: &[usize]) -> ConstraintRows {
    vertices.iter().map(|&i| vec![(i, 1.0)]).collect()
}

/// `Y = H P` for rows `H` and positions `p` (h × 3). Errors on a vertex out
/// of range.
pub fn apply_rows(rows: &ConstraintRows, p: &[Point]) -> Result<DMatrix<f64>> {
    let mut y = DMatrix::zeros(rows.len(), 3);
    for (r, row) in rows.iter().enumerate() {
        for &(i, w) in row {
            let v = p.get(i).ok_or_else(|| {
                Error::invalid(format!(
                    "constraint row {r} uses vertex {i} of {} points",
                    p.len()
                ))
            })?;
            for c in 0..3 {
                y[(r, c)] += w * v[c];
            }
        }
    }
    Ok(y)
}

/// Radii `k/n_circles · max_radius`, k = 1..=n_circles.
pub fn circle_radii(n_circles: usize, max_radius: f64) -> Vec<f64> {
    (1..=n_circles)
        .map(|k| k as f64 / n_circles as f64 * max_radius)
        .collect()
}

/// One row per radius: the Voronoi-area-weighted average of the vertices
/// of `mesh` within Dijkstra (edge-path) distance `radius` of `center`
/// (weights sum to one; the center alone if no other vertex is inside).
pub fn geodesic_circle_rows(mesh: &Mesh, center: usize, radii: &[f64]) -> Result<ConstraintRows> {
    circle_rows_with(mesh, &mesh.mass(MassKind::Voronoi), center, radii)
}

fn circle_rows_with(
    mesh: &Mesh,
    mass: &[f64],
    center: usize,
    radii: &[f64],
) -> Result<ConstraintRows> {
    if center >= mesh.n_vertices() {
        return Err(Error::invalid(format!(
            "feature vertex {center} out of range ({} vertices)",
            mesh.n_vertices()
        )));
    }
    let dist = dijkstra_distances(mesh, &[center])?;
    let mut order: Vec<usize> = (0..dist.len()).filter(|&i| dist[i].is_finite()).collect();
    order.sort_by(|&a, &b| dist[a].total_cmp(&dist[b]).then(a.cmp(&b)));
    radii
        .iter()
        .map(|&r| {
            let inside: Vec<usize> = order
                .iter()
                .copied()
                .take_while(|&i| dist[i] <= r)
                .collect();
            let inside = if inside.is_empty() {
                vec![center]
            } else {
                inside
            };
            let total: f64 = inside.iter().map(|&i| mass[i]).sum();
            if total > 0.0 {
                Ok(inside.iter().map(|&i| (i, mass[i] / total)).collect())
            } else {
                let w = 1.0 / inside.len() as f64;
                Ok(inside.iter().map(|&i| (i, w)).collect())
            }
        })
        .collect()
}

/// Feature-point constraints (Sec. 5): for each pair (template vertex,
/// target vertex) of `features`, `radii.len()` rows on the template (`H`,
/// circles around the template vertex) and the matching averages over the
/// target's circles around its vertex (`Y`). Rows are grouped by feature:
/// rows `f·c .. (f+1)·c` belong to feature f (c = number of radii).
pub fn feature_circle_constraints(
    template: &Mesh,
    target: &Mesh,
    features: &[(usize, usize)],
    radii: &[f64],
) -> Result<(ConstraintRows, DMatrix<f64>)> {
    let tm = template.mass(MassKind::Voronoi);
    let gm = target.mass(MassKind::Voronoi);
    let mut rows = Vec::new();
    let mut trows = Vec::new();
    for &(a, b) in features {
        rows.extend(circle_rows_with(template, &tm, a, radii)?);
        trows.extend(circle_rows_with(target, &gm, b, radii)?);
    }
    let y = apply_rows(&trows, target.vertices())?;
    Ok((rows, y))
}

/// Row indices of each feature for constraints built with `per_feature`
/// rows per feature.
pub fn feature_row_groups(n_features: usize, per_feature: usize) -> Vec<Vec<usize>> {
    (0..n_features)
        .map(|f| (f * per_feature..(f + 1) * per_feature).collect())
        .collect()
}

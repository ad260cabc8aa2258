//! Normalising a set of meshes into the unit sphere with one similarity.
//!
//! BDT scales its data "consistently to fit into a unit sphere": every mesh of
//! a set gets the *same* translation and uniform scale, so that relative
//! sizes and positions (e.g. of a source and its deformed poses) are kept.
//! The transform is `x ↦ (x − c) · s` where
//!
//! * `c` is the centre of the axis-aligned bounding box of the reference
//!   vertices, and
//! * `s = 1 / max ‖x − c‖` over the reference vertices,
//!
//! so that every reference vertex ends up in the closed unit ball and at
//! least one lies on the unit sphere. (The bounding-box centre is not the
//! minimal enclosing ball's centre, so the ball can be up to √3/2·diagonal
//! larger than necessary; it is simple, deterministic and independent of
//! sampling density, unlike the centroid.)
//!
//! The reference is chosen by [`NormalizeReference`]: the union of all
//! meshes (default: *every* mesh fits in the unit ball) or only the first
//! mesh (the others keep their size relative to it and may stick out).

use std::sync::Mutex;

use crate::mesh::derived::Key;
use crate::mesh::{check_extent, stable_norm, Mesh};
use crate::{Error, Point, Result, Vec3};

/// Which vertices define the normalising transform.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum NormalizeReference {
    /// All vertices of all meshes: every mesh fits in the unit ball.
    #[default]
    Union,
    /// The vertices of the first mesh only.
    First,
}

/// How many similarity copies of a mesh [`Similarity::apply_mesh`] keeps.
pub const SIMILAR_COPIES: usize = 1;

/// The similarity copies of a mesh, by the bits of (center, scale).
struct SimilarCopies;
impl Key for SimilarCopies {
    type Value = Mutex<Vec<([u64; 4], Mesh)>>;
}

/// The similarity `x ↦ (x − center) · scale` (uniform scale, no rotation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    /// Point mapped to the origin.
    pub center: Point,
    /// Uniform scale factor (> 0).
    pub scale: f64,
}

impl Similarity {
    /// Applies the transform to a point.
    pub fn apply(&self, p: &Point) -> Point {
        Point::from((p - self.center) * self.scale)
    }

    /// Undoes [`Similarity::apply`].
    pub fn invert(&self, p: &Point) -> Point {
        self.center + p.coords / self.scale
    }

    /// Applies the transform to a displacement or edge vector (scale only).
    pub fn apply_vector(&self, v: &Vec3) -> Vec3 {
        v * self.scale
    }

    /// Applies the transform to every vertex of a mesh.
    ///
    /// The copy is kept with `mesh` (its last copy: [`SIMILAR_COPIES`]):
    /// normalising the same mesh by the same similarity again returns a
    /// clone of the same copy, which shares the operators computed on it
    /// ([`super::Operators`]).
    pub fn apply_mesh(&self, mesh: &Mesh) -> Result<Mesh> {
        let key = [
            self.center.x.to_bits(),
            self.center.y.to_bits(),
            self.center.z.to_bits(),
            self.scale.to_bits(),
        ];
        let copies = mesh
            .geometry_values()
            .get::<SimilarCopies>(Default::default);
        let mut copies = copies.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, m)) = copies.iter().find(|(k, _)| *k == key) {
            return Ok(m.clone());
        }
        let m = mesh.map_vertices(|p| self.apply(p))?;
        if copies.len() == SIMILAR_COPIES {
            copies.remove(0);
        }
        copies.push((key, m.clone()));
        Ok(m)
    }

    /// Undoes the transform on every vertex of a mesh.
    pub fn invert_mesh(&self, mesh: &Mesh) -> Result<Mesh> {
        mesh.map_vertices(|p| self.invert(p))
    }
}

/// The normalising similarity of `meshes` (see the module documentation).
/// Errors if `meshes` is empty, the reference vertices all coincide, or
/// their extent is outside [`crate::mesh::EXTENT_RANGE`] (the error says
/// overflow or underflow).
pub fn unit_sphere_transform(meshes: &[Mesh], reference: NormalizeReference) -> Result<Similarity> {
    let refs: &[Mesh] = match reference {
        NormalizeReference::Union => meshes,
        NormalizeReference::First => meshes.get(..1).unwrap_or(&[]),
    };
    let mut points = refs.iter().flat_map(|m| m.vertices().iter());
    let Some(first) = points.next() else {
        return Err(Error::invalid("no meshes to normalise"));
    };
    let (mut lo, mut hi) = (first.coords, first.coords);
    for p in points {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let center = Point::from(lo * 0.5 + hi * 0.5);
    let radius = refs
        .iter()
        .flat_map(|m| m.vertices().iter())
        .map(|p| stable_norm(&(p - center)))
        .fold(0.0f64, f64::max);
    check_extent(radius).map_err(|e| Error::invalid(format!("cannot normalise: {e}")))?;
    if radius == 0.0 {
        return Err(Error::invalid(
            "cannot normalise: all reference vertices coincide",
        ));
    }
    Ok(Similarity {
        center,
        scale: 1.0 / radius,
    })
}

/// Normalises all `meshes` with one similarity (see the module
/// documentation); returns the transform, to undo it later, and the
/// transformed meshes in input order.
pub fn normalize_to_unit_sphere(
    meshes: &[Mesh],
    reference: NormalizeReference,
) -> Result<(Similarity, Vec<Mesh>)> {
    let t = unit_sphere_transform(meshes, reference)?;
    let out = meshes
        .iter()
        .map(|m| t.apply_mesh(m))
        .collect::<Result<Vec<_>>>()?;
    Ok((t, out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::primitives::{grid, icosphere};

    #[test]
    fn overflow_and_underflow_are_named_not_coincidence() {
        for (s, word) in [(1e200, "overflow"), (1e-200, "underflow")] {
            let m = icosphere(1)
                .map_vertices(|p| Point::from(p.coords * s))
                .unwrap();
            let e = unit_sphere_transform(&[m], NormalizeReference::Union)
                .unwrap_err()
                .to_string();
            assert!(e.contains(word) && !e.contains("coincide"), "{e}");
        }
        // Large but representable: normalised as usual.
        let m = icosphere(1)
            .map_vertices(|p| Point::from(p.coords * 1e40))
            .unwrap();
        let t = unit_sphere_transform(&[m], NormalizeReference::Union).unwrap();
        assert!((t.scale * 1e40 - 1.0).abs() < 1e-9, "{}", t.scale);
    }

    #[test]
    fn union_fits_all_and_is_invertible() {
        let a = icosphere(1)
            .map_vertices(|p| Point::from(p.coords * 3.0 + Vec3::new(1.0, 2.0, 3.0)))
            .unwrap();
        let b = a.map_vertices(|p| p + Vec3::new(4.0, 0.0, 0.0)).unwrap();
        let (t, out) =
            normalize_to_unit_sphere(&[a.clone(), b.clone()], NormalizeReference::Union).unwrap();
        let max = out
            .iter()
            .flat_map(|m| m.vertices())
            .map(|p| p.coords.norm())
            .fold(0.0, f64::max);
        assert!((max - 1.0).abs() < 1e-12);
        // Same transform on both: the offset between them is kept (scaled).
        let d = out[1].vertices()[0] - out[0].vertices()[0];
        assert!((d - t.apply_vector(&Vec3::new(4.0, 0.0, 0.0))).norm() < 1e-12);
        let back = t.invert_mesh(&out[1]).unwrap();
        for (p, q) in back.vertices().iter().zip(b.vertices()) {
            assert!((p - q).norm() < 1e-12);
        }
    }

    #[test]
    fn first_reference() {
        let a = icosphere(1);
        let b = a.map_vertices(|p| Point::from(p.coords * 2.0)).unwrap();
        let (t, out) = normalize_to_unit_sphere(&[a, b], NormalizeReference::First).unwrap();
        assert!((t.scale - 1.0).abs() < 1e-12);
        assert!(t.center.coords.norm() < 1e-12);
        let r: f64 = out[1]
            .vertices()
            .iter()
            .map(|p| p.coords.norm())
            .fold(0.0, f64::max);
        assert!((r - 2.0).abs() < 1e-12);
    }

    #[test]
    fn bad_input() {
        assert!(normalize_to_unit_sphere(&[], NormalizeReference::Union).is_err());
        let flat = grid(1, 1).map_vertices(|_| Point::origin()).unwrap();
        assert!(unit_sphere_transform(&[flat], NormalizeReference::First).is_err());
    }
}

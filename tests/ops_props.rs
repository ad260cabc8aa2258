//! Property tests for the discrete operators in `deformlab::ops`, over random
//! closed meshes (perturbed icospheres and tori) under random similarity
//! transforms. Case counts are small so the file runs in seconds:
//! `cargo test --release --test ops_props`.

use std::f64::consts::PI;

use deformlab::mesh::primitives::{grid, icosphere, torus};
use deformlab::ops::heat::{HeatGeodesics, HeatOptions};
use deformlab::ops::rotation::{axis_angle_to_paper, rotation_exp_axis_angle};
use deformlab::ops::sampling::seeded_first_vertex;
use deformlab::ops::*;
use deformlab::{Mat3, Mesh, Point, Vec3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

// ---------------------------------------------------------------------------
// Generators
// ---------------------------------------------------------------------------

/// A random closed mesh, described by its parameters (so failures print
/// something readable) and built deterministically from them.
#[derive(Clone, Debug)]
enum ClosedMesh {
    /// Icosphere of `level`, each vertex moved radially by a factor
    /// `1 + noise·u`, `u` uniform in [−1, 1] from `seed`.
    Sphere { level: u32, noise: f64, seed: u64 },
    /// Torus with the tube radius of each vertex scaled by `1 + noise·u`.
    Torus {
        major: f64,
        minor: f64,
        nu: usize,
        nv: usize,
        noise: f64,
        seed: u64,
    },
}

impl ClosedMesh {
    fn build(&self) -> Mesh {
        match *self {
            ClosedMesh::Sphere { level, noise, seed } => {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                let s = icosphere(level);
                let moved = s
                    .vertices()
                    .iter()
                    .map(|p| p * (1.0 + noise * rng_unit(&mut rng)))
                    .collect();
                s.with_vertices(moved).unwrap()
            }
            ClosedMesh::Torus {
                major,
                minor,
                nu,
                nv,
                noise,
                seed,
            } => {
                let t = torus(major, minor, nu, nv);
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                let moved: Vec<Point> = t
                    .vertices()
                    .iter()
                    .map(|p| {
                        let ring = Vec3::new(p.x, p.y, 0.0).normalize() * major;
                        let tube = p.coords - ring;
                        Point::from(ring + tube * (1.0 + noise * rng_unit(&mut rng)))
                    })
                    .collect();
                t.with_vertices(moved).unwrap()
            }
        }
    }
}

fn rng_unit(rng: &mut ChaCha8Rng) -> f64 {
    rng.random_range(-1.0..=1.0)
}

fn closed_mesh() -> impl Strategy<Value = ClosedMesh> {
    prop_oneof![
        (2u32..=3, 0.0..0.15f64, any::<u64>())
            .prop_map(|(level, noise, seed)| ClosedMesh::Sphere { level, noise, seed }),
        (
            1.5..3.0f64,
            0.3..0.8f64,
            8usize..20,
            6usize..12,
            0.0..0.2f64,
            any::<u64>()
        )
            .prop_map(|(major, minor, nu, nv, noise, seed)| ClosedMesh::Torus {
                major,
                minor,
                nu,
                nv,
                noise,
                seed
            }),
    ]
}

/// Unit vector from spherical coordinates.
fn unit_vector() -> impl Strategy<Value = Vec3> {
    (0.0..2.0 * PI, -1.0..=1.0f64).prop_map(|(phi, z): (f64, f64)| {
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    })
}

/// Axis–angle vector with angle in `[0, π − 0.01]` (log is unique there).
fn axis_angle() -> impl Strategy<Value = Vec3> {
    (unit_vector(), 0.0..PI - 0.01).prop_map(|(a, t)| a * t)
}

/// `x ↦ scale · R x + t`.
#[derive(Clone, Debug)]
struct SimilarityMotion {
    omega: Vec3,
    scale: f64,
    shift: Vec3,
}

impl SimilarityMotion {
    fn rotation(&self) -> Mat3 {
        rotation_exp_axis_angle(&self.omega)
    }
    fn apply(&self, mesh: &Mesh) -> Mesh {
        let r = self.rotation();
        mesh.map_vertices(|p| Point::from(self.scale * (r * p.coords) + self.shift))
            .unwrap()
    }
}

fn motion(uniform_scale: bool) -> impl Strategy<Value = SimilarityMotion> {
    // Scale in [0.3, 3], log-uniform, or exactly 1 for a rigid motion.
    let log_range = if uniform_scale {
        0.3f64.ln()..=3.0f64.ln()
    } else {
        0.0..=0.0
    };
    (axis_angle(), log_range, prop::array::uniform3(-5.0..5.0f64)).prop_map(
        |(omega, log_scale, s)| SimilarityMotion {
            omega,
            scale: log_scale.exp(),
            shift: Vec3::new(s[0], s[1], s[2]),
        },
    )
}

/// 24 cases by default; `PROPTEST_CASES=n` overrides (for longer soak runs).
fn config() -> ProptestConfig {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(24);
    ProptestConfig {
        cases,
        max_shrink_iters: 200,
        ..ProptestConfig::default()
    }
}

fn max_abs_diff(a: &Mat3, b: &Mat3) -> f64 {
    (a - b).abs().max()
}

// ---------------------------------------------------------------------------
// Geodesic checks shared by all distance methods
// ---------------------------------------------------------------------------

/// Relative-error bounds of a geodesic method against great-circle distances
/// on a sphere: `lo ≤ d / d_true − 1 ≤ hi` at every target, and the mean
/// relative error at most `mean_max`.
struct GeodesicBounds {
    lo: f64,
    hi: f64,
    mean_max: f64,
}

/// Checks `dist` (distances from vertex `source` on `sphere`, the unit
/// icosphere scaled by `scale` and moved rigidly) against `scale ·` the great
/// circle distance on the unit sphere `unit`.
fn check_sphere_geodesics(
    unit: &Mesh,
    scale: f64,
    source: usize,
    dist: &[f64],
    bounds: &GeodesicBounds,
) -> Result<(), TestCaseError> {
    let v = unit.vertices();
    prop_assert_eq!(dist.len(), v.len());
    prop_assert!(dist[source].abs() <= 1e-12 * scale);
    let (mut sum, mut count) = (0.0, 0usize);
    for (j, &d) in dist.iter().enumerate() {
        if j == source {
            continue;
        }
        let gc = scale * v[source].coords.dot(&v[j].coords).clamp(-1.0, 1.0).acos();
        let rel = d / gc - 1.0;
        prop_assert!(
            rel >= bounds.lo && rel <= bounds.hi,
            "target {}: distance {} vs great circle {} (rel {})",
            j,
            d,
            gc,
            rel
        );
        sum += rel;
        count += 1;
    }
    let mean = sum / count as f64;
    prop_assert!(mean <= bounds.mean_max, "mean relative error {}", mean);
    Ok(())
}

/// Largest edge angle (radians) of a mesh on the unit sphere.
fn max_edge_angle(unit: &Mesh) -> f64 {
    let v = unit.vertices();
    edges(unit)
        .iter()
        .map(|&(i, j)| v[i].coords.dot(&v[j].coords).clamp(-1.0, 1.0).acos())
        .fold(0.0, f64::max)
}

// ---------------------------------------------------------------------------
// Properties
// ---------------------------------------------------------------------------

proptest! {
    #![proptest_config(config())]

    #[test]
    fn laplacian_symmetric_with_zero_row_sums(m in closed_mesh(), t in motion(true)) {
        let mesh = t.apply(&m.build());
        let l = cotan_laplacian(&mesh);
        let dense = nalgebra::DMatrix::from(&l);
        let scale = dense.abs().max();
        prop_assert!(scale > 0.0);
        prop_assert!((&dense - dense.transpose()).abs().max() <= 1e-14 * scale);
        for i in 0..dense.nrows() {
            prop_assert!(dense.row(i).sum().abs() <= 1e-12 * scale, "row {}", i);
        }
    }

    #[test]
    fn laplacian_kills_linear_functions_on_perturbed_flat_grid(
        nx in 3usize..8,
        ny in 3usize..8,
        amp in 0.0..0.2f64,
        seed in any::<u64>(),
        coef in prop::array::uniform4(-3.0..3.0f64),
        t in motion(true),
    ) {
        let g = grid(nx, ny);
        let boundary = boundary_vertices(&g);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (hx, hy) = (1.0 / nx as f64, 1.0 / ny as f64);
        // Interior vertices move by less than a fifth of a cell in x and y,
        // so no triangle flips; the grid stays planar.
        let moved: Vec<Point> = g
            .vertices()
            .iter()
            .zip(&boundary)
            .map(|(p, &b)| {
                if b {
                    *p
                } else {
                    let dx = amp * hx * rng_unit(&mut rng);
                    let dy = amp * hy * rng_unit(&mut rng);
                    Point::new(p.x + dx, p.y + dy, 0.0)
                }
            })
            .collect();
        let flat = t.apply(&g.with_vertices(moved).unwrap());
        let f: Vec<f64> = flat
            .vertices()
            .iter()
            .map(|p| coef[0] * p.x + coef[1] * p.y + coef[2] * p.z + coef[3])
            .collect();
        let l = cotan_laplacian(&flat);
        let mut lf = vec![0.0; f.len()];
        let mut lmax = 0.0f64;
        for (i, j, x) in l.triplet_iter() {
            lf[i] += x * f[j];
            lmax = lmax.max(x.abs());
        }
        let fmax = f.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for (i, (&b, &y)) in boundary.iter().zip(&lf).enumerate() {
            if !b {
                prop_assert!(y.abs() <= 1e-11 * lmax * fmax.max(1.0), "vertex {}: {}", i, y);
            }
        }
    }

    #[test]
    fn mass_sums_to_total_area(m in closed_mesh(), t in motion(true)) {
        let mesh = t.apply(&m.build());
        let area = total_area(&mesh);
        for kind in [MassKind::Voronoi, MassKind::Barycentric] {
            let mass = mass_matrix(&mesh, kind);
            prop_assert!(mass.iter().all(|&x| x > 0.0));
            let sum: f64 = mass.iter().sum();
            prop_assert!((sum - area).abs() <= 1e-12 * area, "{:?}: {} vs {}", kind, sum, area);
        }
    }

    #[test]
    fn deformation_gradient_of_rigid_motion(m in closed_mesh(), t in motion(false)) {
        check_similarity_gradient(&m.build(), &t)?;
    }

    #[test]
    fn deformation_gradient_of_similarity(m in closed_mesh(), t in motion(true)) {
        check_similarity_gradient(&m.build(), &t)?;
    }

    #[test]
    fn polar_decomposition_reconstructs(entries in prop::array::uniform9(-3.0..3.0f64)) {
        let d = Mat3::from_row_slice(&entries);
        let p = polar_decomposition(&d).unwrap();
        let u = p.rotation;
        let tol = 1e-12 * d.abs().max().max(1.0);
        prop_assert!(max_abs_diff(&(u.transpose() * u), &Mat3::identity()) <= 1e-12);
        prop_assert!((u.determinant() - 1.0).abs() <= 1e-12);
        prop_assert!(max_abs_diff(&p.stretch, &p.stretch.transpose()) <= tol);
        prop_assert!(max_abs_diff(&(u * p.stretch), &d) <= tol);
        if d.determinant() > 1e-9 {
            // Proper D: N is positive definite.
            prop_assert!(p.stretch.symmetric_eigenvalues().min() > 0.0);
        }
    }

    #[test]
    fn exp_of_log_is_identity_on_rotations(
        axis in unit_vector(),
        angle in prop_oneof![0.0..1e-6f64, 0.0..PI, (PI - 1e-6)..=PI],
    ) {
        let r = rotation_exp_axis_angle(&(axis * angle));
        let u = rotation_log(&r);
        prop_assert!((u.norm() - angle).abs() <= 1e-9);
        prop_assert!(max_abs_diff(&rotation_exp(&u), &r) <= 1e-13);
        if angle < PI - 1e-6 {
            prop_assert!((u - axis_angle_to_paper(&(axis * angle))).norm() <= 1e-9);
        }
    }

    #[test]
    fn fps_is_distinct_and_farthest(
        m in closed_mesh(),
        t in motion(true),
        k in 1usize..16,
        geodesic in any::<bool>(),
        seed in any::<u64>(),
    ) {
        let mesh = t.apply(&m.build());
        let metric = if geodesic { FpsMetric::Geodesic } else { FpsMetric::Euclidean };
        let s = farthest_point_sampling(&mesh, k, metric, seed).unwrap();
        prop_assert_eq!(s.len(), k);
        prop_assert_eq!(s[0], seeded_first_vertex(&mesh, seed));
        let mut sorted = s.clone();
        sorted.sort_unstable();
        sorted.dedup();
        prop_assert_eq!(sorted.len(), k, "repeated sample in {:?}", s);
        let v = mesh.vertices();
        let tol = 1e-12 * t.scale * 10.0;
        for m_idx in 1..k {
            let before = &s[..m_idx];
            let min_dist: Vec<f64> = match metric {
                FpsMetric::Geodesic => dijkstra_distances(&mesh, before).unwrap(),
                FpsMetric::Euclidean => v
                    .iter()
                    .map(|p| before.iter().map(|&b| (p - v[b]).norm()).fold(f64::INFINITY, f64::min))
                    .collect(),
            };
            let best = min_dist.iter().cloned().fold(0.0, f64::max);
            prop_assert!(
                min_dist[s[m_idx]] >= best - tol,
                "sample {} (vertex {}) at {} but farthest is {}",
                m_idx, s[m_idx], min_dist[s[m_idx]], best
            );
        }
    }

    #[test]
    fn dijkstra_on_sphere_within_documented_error(
        level in 2u32..=3,
        t in motion(true),
        source_frac in 0.0..1.0f64,
    ) {
        let unit = icosphere(level);
        let sphere = t.apply(&unit);
        let source = ((source_frac * unit.n_vertices() as f64) as usize).min(unit.n_vertices() - 1);
        let dist = dijkstra_distances(&sphere, &[source]).unwrap();
        // Documented in ops::geodesic: at most +23.6 % (all pairs, levels
        // 2–5), mean over the targets of one source at most +8.6 %, and below
        // only by the chord deficit of one edge, θ²/24.
        let theta = max_edge_angle(&unit);
        let bounds = GeodesicBounds { lo: -theta * theta / 24.0 - 1e-9, hi: 0.25, mean_max: 0.09 };
        check_sphere_geodesics(&unit, t.scale, source, &dist, &bounds)?;
    }

    #[test]
    fn heat_on_sphere_within_documented_error(
        t in motion(true),
        source_frac in 0.0..1.0f64,
    ) {
        let unit = icosphere(3);
        let sphere = t.apply(&unit);
        let source = ((source_frac * unit.n_vertices() as f64) as usize).min(unit.n_vertices() - 1);
        let heat = HeatGeodesics::new(&sphere, &HeatOptions::default()).unwrap();
        let dist = heat.distance(&[source]).unwrap();
        // Documented in ops::heat for level 3 (642 vertices): mean relative
        // error 1.99 %, max 19.1 % (on the first ring around the source).
        // Bounds: ±21 % everywhere, signed mean ≤ 2.5 %, independent of the
        // rigid motion and the scale.
        let bounds = GeodesicBounds { lo: -0.21, hi: 0.21, mean_max: 0.025 };
        check_sphere_geodesics(&unit, t.scale, source, &dist, &bounds)?;
    }
}

fn check_similarity_gradient(rest: &Mesh, t: &SimilarityMotion) -> Result<(), TestCaseError> {
    let deformed = t.apply(rest);
    let r = t.rotation();
    let expect = t.scale * r;
    let grads = deformation_gradients(rest, &deformed).unwrap();
    for (i, g) in grads.iter().enumerate() {
        prop_assert!(
            max_abs_diff(g, &expect) <= 1e-9 * t.scale,
            "vertex {}: {:?} vs {:?}",
            i,
            g,
            expect
        );
    }
    let f = deformation_features(rest, &deformed).unwrap();
    let u = axis_angle_to_paper(&t.omega);
    for i in 0..rest.n_vertices() {
        let got = Vec3::new(
            f.log_rotation[(i, 0)],
            f.log_rotation[(i, 1)],
            f.log_rotation[(i, 2)],
        );
        prop_assert!(
            (got - u).norm() <= 1e-8,
            "vertex {}: {:?} vs {:?}",
            i,
            got,
            u
        );
        for k in 0..9 {
            let e = if k % 4 == 0 { t.scale } else { 0.0 };
            prop_assert!((f.scale_shear[(i, k)] - e).abs() <= 1e-9 * t.scale);
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// Unit tests with known analytic values
// ---------------------------------------------------------------------------

#[test]
fn icosahedron_analytic_values() {
    let m = icosphere(0);
    // Edge length of the icosahedron inscribed in the unit sphere.
    let a = 4.0 / (10.0 + 2.0 * 5f64.sqrt()).sqrt();
    let d = dijkstra_distances(&m, &[0]).unwrap();
    let mut sorted = d.clone();
    sorted.sort_by(f64::total_cmp);
    // 1 source, 5 neighbours at a, 5 at 2a, antipode at 3a.
    assert_eq!(sorted[0], 0.0);
    assert!(sorted[1..6].iter().all(|x| (x - a).abs() < 1e-12));
    assert!(sorted[6..11].iter().all(|x| (x - 2.0 * a).abs() < 1e-12));
    assert!((sorted[11] - 3.0 * a).abs() < 1e-12);
    // Total area 5√3 a².
    assert!((total_area(&m) - 5.0 * 3f64.sqrt() * a * a).abs() < 1e-12);
    // Vertex normals of the regular icosahedron are exactly radial.
    for (p, n) in m.vertices().iter().zip(vertex_normals(&m)) {
        assert!((n - p.coords).norm() < 1e-12);
    }
}

#[test]
fn rotation_about_x_in_paper_basis() {
    // 60° about +x: ω = (π/3, 0, 0) → u = (0, 0, −π/3), i.e. −π/3 · e₃.
    let c = 0.5;
    let s = 3f64.sqrt() / 2.0;
    let r = Mat3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c);
    let u = rotation_log(&r);
    assert!((u - Vec3::new(0.0, 0.0, -PI / 3.0)).norm() < 1e-15);
}

#[test]
fn shear_gradient_on_flat_grid() {
    // A shear x += 0.5 y keeps areas, so the normal term maps the normal to
    // itself: D = [[1, .5, 0], [0, 1, 0], [0, 0, 1]] at every vertex.
    let g = grid(5, 5);
    let sheared = g
        .map_vertices(|p| Point::new(p.x + 0.5 * p.y, p.y, 0.0))
        .unwrap();
    let expect = Mat3::new(1.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
    for d in deformation_gradients(&g, &sheared).unwrap() {
        assert!(max_abs_diff(&d, &expect) < 1e-10);
    }
    let f = deformation_features(&g, &sheared).unwrap();
    // Polar of the shear: rotation about z by atan(−0.25) ... check
    // reconstruction rather than a closed form.
    for i in 0..g.n_vertices() {
        let u = Vec3::new(
            f.log_rotation[(i, 0)],
            f.log_rotation[(i, 1)],
            f.log_rotation[(i, 2)],
        );
        let row: Vec<f64> = f.scale_shear.row(i).iter().copied().collect();
        let n = Mat3::from_row_slice(&row);
        assert!(max_abs_diff(&(rotation_exp(&u) * n), &expect) < 1e-10);
        // In-plane rotation: only the e₁ (xy) component is non-zero.
        assert!(u[1].abs() < 1e-12 && u[2].abs() < 1e-12);
    }
}

#[test]
fn normalised_set_fits_unit_ball() {
    let a = torus(2.0, 0.5, 12, 8);
    let b = a
        .map_vertices(|p| Point::new(p.x * 1.2, p.y, p.z + 1.0))
        .unwrap();
    let (t, out) = normalize_to_unit_sphere(&[a, b.clone()], NormalizeReference::Union).unwrap();
    let r = out
        .iter()
        .flat_map(|m| m.vertices())
        .map(|p| p.coords.norm())
        .fold(0.0, f64::max);
    assert!((r - 1.0).abs() < 1e-12);
    let back = t.invert_mesh(&out[1]).unwrap();
    assert!(back
        .vertices()
        .iter()
        .zip(b.vertices())
        .all(|(p, q)| (p - q).norm() < 1e-12));
}

//! Defect report: every planted defect is counted exactly; primitives are
//! clean with the right topology; real data defects are found. The
//! result-changing defects (issue 18): listed per kind, repaired where the
//! repair is standard, and handled where meshes are loaded for a
//! computation (`run`, `transfer`, `keypoints`: one warning per file and
//! kind, recorded; `--strict` refuses; `--repair` repairs and says so);
//! `inspect` exits non-zero for an empty mesh.

mod common;

use std::path::Path;

use common::{csv_rows, deformlab, ok, tmp, write};
use deformlab::data::shared_data_or_skip;
use deformlab::data::synthetic::FaustStyle;
use deformlab::mesh::io::{read_raw, write_ply};
use deformlab::mesh::primitives::{grid, icosphere, torus};
use deformlab::mesh::repair::{DefectPolicy, FaceRepair};
use deformlab::mesh::validate::{DefectKind, DefectReport, LIST_CAP};
use deformlab::mesh::{Face, Mesh, RawMesh};
use deformlab::Point;

fn p(x: f64, y: f64, z: f64) -> Point {
    Point::new(x, y, z)
}

/// A closed, consistently (outward) wound tetrahedron.
fn tetra() -> RawMesh {
    RawMesh {
        vertices: vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.0, 0.0, 1.0),
        ],
        faces: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    }
}

fn with_faces(mut m: RawMesh, extra: &[Face]) -> RawMesh {
    m.faces.extend_from_slice(extra);
    m
}

/// Counts of every defect list, in a fixed order, for compact assertions:
/// [out_of_range, non_finite, repeated, zero_area, duplicate, unreferenced,
///  boundary, non_manifold_edges, non_manifold_vertices, inconsistent].
fn counts(r: &DefectReport) -> [usize; 10] {
    [
        r.out_of_range_faces.count,
        r.non_finite_vertices.count,
        r.repeated_index_faces.count,
        r.zero_area_faces.count,
        r.duplicate_faces.count,
        r.unreferenced_vertices.count,
        r.boundary_edges.count,
        r.non_manifold_edges.count,
        r.non_manifold_vertices.count,
        r.inconsistent_edges.count,
    ]
}

#[test]
fn tetrahedron_is_clean() {
    let r = DefectReport::of(&tetra());
    assert!(r.is_clean(), "{r}");
    assert_eq!(counts(&r), [0; 10]);
    assert_eq!((r.n_vertices, r.n_faces, r.n_edges), (4, 4, 6));
    assert_eq!(r.euler_characteristic, 2);
    assert_eq!(r.genus(), Some(0));
    assert_eq!(r.components.len(), 1);
    assert_eq!(r.components[0].faces_to_flip, Some(0));
}

#[test]
fn primitives_are_clean_with_right_topology() {
    for level in 0..4 {
        let r = DefectReport::of_mesh(&icosphere(level));
        assert!(r.is_clean(), "{r}");
        assert_eq!(r.euler_characteristic, 2);
        assert_eq!(r.genus(), Some(0));
    }
    for (nu, nv) in [(3, 3), (12, 8), (40, 17)] {
        let r = DefectReport::of_mesh(&torus(2.0, 0.5, nu, nv));
        assert!(r.is_clean(), "{r}");
        assert_eq!(r.euler_characteristic, 0);
        assert_eq!(r.genus(), Some(1));
        assert_eq!(r.components.len(), 1);
    }
    // An open grid: one boundary loop, a disk.
    let r = DefectReport::of_mesh(&grid(4, 3));
    assert!(!r.is_clean() && r.is_clean_ignoring_boundary(), "{r}");
    assert_eq!(r.boundary_edges.count, 2 * (4 + 3));
    let c = &r.components[0];
    assert_eq!(
        (c.euler_characteristic, c.boundary_loops, c.genus),
        (1, 1, Some(0))
    );
}

#[test]
fn two_components_sum_up() {
    let s = icosphere(1);
    let t = torus(2.0, 0.5, 10, 6);
    let n = s.n_vertices();
    let mut vertices = s.vertices().to_vec();
    vertices.extend(t.vertices().iter().map(|q| p(q.x + 10.0, q.y, q.z)));
    let mut faces = s.faces().to_vec();
    faces.extend(t.faces().iter().map(|f| [f[0] + n, f[1] + n, f[2] + n]));
    let r = DefectReport::of(&RawMesh { vertices, faces });
    assert!(r.is_clean(), "{r}");
    assert_eq!(r.components.len(), 2);
    assert_eq!(r.euler_characteristic, 2);
    assert_eq!(r.genus(), Some(1));
    assert_eq!(r.components[1].first_face, s.n_faces());
}

#[test]
fn out_of_range_faces() {
    let m = with_faces(tetra(), &[[0, 1, 9], [7, 8, 9]]);
    let r = DefectReport::of(&m);
    assert_eq!(counts(&r), [2, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(r.out_of_range_faces.first, vec![4, 5]);
    assert!(!r.is_loadable() && !r.is_clean());
    // Out-of-range faces are left out of the topology.
    assert_eq!(r.genus(), Some(0));
}

#[test]
fn non_finite_vertices() {
    let mut m = tetra();
    m.vertices[3].y = f64::NAN;
    m.vertices[1].x = f64::INFINITY;
    let r = DefectReport::of(&m);
    assert_eq!(counts(&r), [0, 2, 0, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(r.non_finite_vertices.first, vec![1, 3]);
    assert!(!r.is_loadable());
}

#[test]
fn zero_area_faces() {
    let m = RawMesh {
        vertices: vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(2.0, 0.0, 0.0),   // collinear with 0, 1
            p(0.5, 1e-12, 0.0), // needle apex, height 1e-12
            p(0.5, 1e-4, 0.0),  // thin but not degenerate
            p(5.0, 5.0, 5.0),   // three coincident points
            p(5.0, 5.0, 5.0),
            p(5.0, 5.0, 5.0),
        ],
        faces: vec![[0, 1, 2], [0, 1, 3], [0, 1, 4], [5, 6, 7]],
    };
    let r = DefectReport::of(&m);
    assert_eq!(r.zero_area_faces.count, 3, "{r}");
    assert_eq!(r.zero_area_faces.first, vec![0, 1, 3]);
    assert_eq!(r.repeated_index_faces.count, 0);
    assert_eq!(r.duplicate_faces.count, 0);
    assert_eq!(r.unreferenced_vertices.count, 0);
    // The scale does not matter: the threshold is relative.
    let tiny = RawMesh {
        vertices: m
            .vertices
            .iter()
            .map(|q| Point::from(q.coords * 1e-9))
            .collect(),
        faces: m.faces.clone(),
    };
    assert_eq!(DefectReport::of(&tiny).zero_area_faces.first, vec![0, 1, 3]);
}

#[test]
fn repeated_index_faces() {
    let m = with_faces(tetra(), &[[0, 0, 1], [2, 3, 3]]);
    let r = DefectReport::of(&m);
    assert_eq!(counts(&r), [0, 0, 2, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(r.repeated_index_faces.first, vec![4, 5]);
    assert_eq!(r.genus(), Some(0));
}

#[test]
fn duplicate_faces() {
    // Face 0 is [0, 2, 1]; plant a copy in the same and in reversed winding.
    let m = with_faces(tetra(), &[[2, 1, 0], [1, 2, 0]]);
    let r = DefectReport::of(&m);
    assert_eq!(r.duplicate_faces.count, 2, "{r}");
    assert_eq!(r.duplicate_faces.first, vec![4, 5]);
    // The three edges of face 0 are now used four times each.
    assert_eq!(r.non_manifold_edges.count, 3);
    assert_eq!(r.non_manifold_edges.first, vec![[0, 1], [0, 2], [1, 2]]);
    assert_eq!(r.components[0].genus, None);
}

#[test]
fn unreferenced_vertices() {
    let mut m = tetra();
    m.vertices.push(p(3.0, 3.0, 3.0));
    m.vertices.insert(0, p(-3.0, 3.0, 3.0));
    for f in &mut m.faces {
        for v in f.iter_mut() {
            *v += 1;
        }
    }
    let r = DefectReport::of(&m);
    assert_eq!(counts(&r), [0, 0, 0, 0, 0, 2, 0, 0, 0, 0]);
    assert_eq!(r.unreferenced_vertices.first, vec![0, 5]);
    assert_eq!(r.euler_characteristic, 2);
}

#[test]
fn boundary_edges() {
    let mut m = tetra();
    m.faces.remove(2); // [1, 2, 3]
    let r = DefectReport::of(&m);
    assert_eq!(counts(&r), [0, 0, 0, 0, 0, 0, 3, 0, 0, 0]);
    assert_eq!(r.boundary_edges.first, vec![[1, 2], [1, 3], [2, 3]]);
    let c = &r.components[0];
    assert_eq!(
        (c.euler_characteristic, c.boundary_loops, c.genus),
        (1, 1, Some(0))
    );
}

#[test]
fn non_manifold_edge() {
    // Three triangles on the edge 0-1 (a "book" with three pages).
    let m = RawMesh {
        vertices: vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.5, 1.0, 0.0),
            p(0.5, -1.0, 0.0),
            p(0.5, 0.0, 1.0),
        ],
        faces: vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
    };
    let r = DefectReport::of(&m);
    assert_eq!(counts(&r), [0, 0, 0, 0, 0, 0, 6, 1, 2, 0], "{r}");
    assert_eq!(r.non_manifold_edges.first, vec![[0, 1]]);
    assert_eq!(r.non_manifold_vertices.first, vec![0, 1]);
    let c = &r.components[0];
    assert!(!c.manifold);
    assert_eq!((c.orientable, c.genus), (None, None));
    assert_eq!(r.genus(), None);
}

#[test]
fn non_manifold_vertex_bow_tie() {
    // Two closed tetrahedra sharing the vertex 0 only.
    let t = tetra();
    let mut vertices = t.vertices.clone();
    vertices.extend([p(0.0, -1.0, 0.0), p(-1.0, 0.0, 0.0), p(0.0, 0.0, -1.0)]);
    let mut faces = t.faces.clone();
    faces.extend(
        t.faces
            .iter()
            .map(|f| f.map(|v| if v == 0 { 0 } else { v + 3 })),
    );
    let r = DefectReport::of(&RawMesh { vertices, faces });
    assert_eq!(counts(&r), [0, 0, 0, 0, 0, 0, 0, 0, 1, 0], "{r}");
    assert_eq!(r.non_manifold_vertices.first, vec![0]);
    assert_eq!(r.components.len(), 1);
    assert!(!r.components[0].manifold);
    // χ = 7 − 12 + 8 = 3: no genus for a pinched surface.
    assert_eq!(r.euler_characteristic, 3);
    assert_eq!(r.genus(), None);
}

#[test]
fn inconsistent_winding() {
    let mut m = tetra();
    m.faces[2] = [1, 3, 2];
    let r = DefectReport::of(&m);
    assert_eq!(counts(&r), [0, 0, 0, 0, 0, 0, 0, 0, 0, 3], "{r}");
    assert_eq!(r.inconsistent_edges.first, vec![[1, 2], [1, 3], [2, 3]]);
    let c = &r.components[0];
    assert_eq!(
        (c.orientable, c.faces_to_flip, c.genus),
        (Some(true), Some(1), Some(0))
    );
    assert!(!r.is_clean());

    // Many flipped faces on a torus: the fewest flips is found.
    let t = torus(2.0, 0.5, 10, 6);
    let mut faces = t.faces().to_vec();
    for f in faces.iter_mut().step_by(7) {
        f.swap(1, 2);
    }
    let flipped = faces.len().div_ceil(7);
    let r = DefectReport::of(&RawMesh {
        vertices: t.vertices().to_vec(),
        faces,
    });
    assert_eq!(r.components[0].faces_to_flip, Some(flipped));
    assert_eq!(r.genus(), Some(1));
}

#[test]
fn mobius_strip_is_not_orientable() {
    let n = 12;
    let mut vertices = Vec::new();
    for i in 0..n {
        let u = std::f64::consts::TAU * i as f64 / n as f64;
        for s in [-0.3, 0.3] {
            let r = 1.0 + s * (u / 2.0).cos();
            vertices.push(p(r * u.cos(), r * u.sin(), s * (u / 2.0).sin()));
        }
    }
    let mut faces: Vec<Face> = Vec::new();
    for i in 0..n {
        let (a, b) = (2 * i, 2 * i + 1);
        // The last strip connects to the first with the sides swapped.
        let (c, d) = if i + 1 < n {
            (2 * i + 2, 2 * i + 3)
        } else {
            (1, 0)
        };
        faces.push([a, b, d]);
        faces.push([a, d, c]);
    }
    let r = DefectReport::of(&RawMesh { vertices, faces });
    let c = &r.components[0];
    assert!(c.manifold, "{r}");
    assert_eq!(c.orientable, Some(false));
    assert_eq!((c.faces_to_flip, c.genus), (None, None));
    assert_eq!(c.boundary_loops, 1);
    assert_eq!(r.euler_characteristic, 0);
    assert!(!r.is_clean_ignoring_boundary());
}

#[test]
fn lists_are_capped_and_display_is_readable() {
    let g = grid(20, 20);
    let mut m: RawMesh = g.into();
    m.faces.extend((0..15).map(|i| [i, i, i + 1]));
    let r = DefectReport::of(&m);
    assert_eq!(r.repeated_index_faces.count, 15);
    assert_eq!(r.repeated_index_faces.first.len(), LIST_CAP);
    let s = r.to_string();
    for needle in [
        "441 vertices",
        "faces with repeated vertex",
        "boundary (not a defect): 80 edges in 1 loop",
        "80",
        "800 801 802 803 804 805 806 807 808 809 …",
        "…",
        "genus",
    ] {
        assert!(s.contains(needle), "missing '{needle}' in\n{s}");
    }
}

#[test]
fn real_data_reports() {
    let Some(dir) = shared_data_or_skip("sumner/horse-camel", "real_data_reports") else {
        return;
    };
    let camel = read_raw(&dir.join("camel_ref.obj")).unwrap();
    let r = DefectReport::of(&camel);
    println!("camel_ref.obj\n{r}");
    assert!(r.non_manifold_edges.count > 0, "{r}");
    assert!(r.is_loadable());
    let horse = Mesh::try_from(read_raw(&dir.join("horse_ref.obj")).unwrap()).unwrap();
    let r = DefectReport::of_mesh(&horse);
    println!("horse_ref.obj\n{r}");
    assert_eq!(r.non_manifold_edges.count, 0);
}

/// One line per real file (run with `--nocapture` to read them). Asserts the
/// facts the data README states.
#[test]
fn real_data_survey() {
    let Some(root) = shared_data_or_skip("", "real_data_survey") else {
        return;
    };
    for sub in [
        "faust",
        "cactus",
        "tosca",
        "sumner/cat-lion",
        "sumner/horse-camel",
        "armadillo",
    ] {
        let dir = root.join(sub);
        let Ok(entries) = std::fs::read_dir(&dir) else {
            eprintln!("SKIP {sub}: absent");
            continue;
        };
        let mut files: Vec<_> = entries
            .map(|e| e.unwrap().path())
            .filter(|p| deformlab::mesh::io::Format::of_path(p).is_some())
            .collect();
        files.sort();
        for f in files {
            let r = DefectReport::of(&read_raw(&f).unwrap());
            println!(
                "{sub}/{}: {}",
                f.file_name().unwrap().to_str().unwrap(),
                r.summary()
            );
            assert!(r.is_loadable());
            if sub == "faust" {
                assert!(r.is_clean_ignoring_boundary(), "{}", r.summary());
            }
            if f.ends_with("camel_ref.obj") {
                assert!(r.non_manifold_edges.count > 0);
            }
        }
    }
}

fn kinds(m: &Mesh) -> Vec<DefectKind> {
    DefectReport::of_mesh(m)
        .result_defects()
        .iter()
        .map(|d| d.kind)
        .collect()
}

fn tetra_mesh() -> Mesh {
    Mesh::try_from(tetra()).unwrap()
}

#[test]
fn result_defects_list_each_kind_once_and_not_boundaries() {
    assert!(kinds(&tetra_mesh()).is_empty());
    // An open surface is valid input.
    assert!(kinds(&grid(4, 3)).is_empty());
    let m = tetra_mesh();
    let dup = m
        .with_faces([m.faces(), &[[0, 2, 1], [2, 1, 0]]].concat())
        .unwrap();
    let r = DefectReport::of_mesh(&dup).result_defects();
    // Duplicates, and their edges and vertices used too often.
    let k: Vec<DefectKind> = r.iter().map(|d| d.kind).collect();
    assert_eq!(
        k,
        [
            DefectKind::DuplicateFaces,
            DefectKind::NonManifoldEdges,
            DefectKind::NonManifoldVertices
        ]
    );
    assert_eq!(r[0].to_string(), "2 duplicate faces (first: 4 5)");
    // Flipped face, an unreferenced vertex, a second component.
    let mut raw = tetra();
    raw.faces[3] = [0, 2, 3];
    raw.vertices.push(p(5.0, 5.0, 5.0));
    let far: Vec<Point> = tetra()
        .vertices
        .iter()
        .map(|q| q + Point::new(3.0, 0.0, 0.0).coords)
        .collect();
    raw.vertices.extend(far);
    raw.faces
        .extend(tetra().faces.iter().map(|f| [f[0] + 5, f[1] + 5, f[2] + 5]));
    let m = Mesh::try_from(raw).unwrap();
    assert_eq!(
        kinds(&m),
        [
            DefectKind::InconsistentOrientation,
            DefectKind::SeveralComponents,
            DefectKind::UnreferencedVertices
        ]
    );
    let text: Vec<String> = DefectReport::of_mesh(&m)
        .result_defects()
        .iter()
        .map(|d| d.to_string())
        .collect();
    assert!(
        text[0].contains("1 faces wound against the rest"),
        "{text:?}"
    );
    assert_eq!(text[1], "2 components (faces: 4 4)");
    assert_eq!(text[2], "1 unreferenced vertices (first: 4)");
}

#[test]
fn an_empty_mesh_is_not_clean() {
    let r = DefectReport::of(&RawMesh::default());
    assert!(!r.is_clean());
    assert!(r.summary().contains("empty (no faces)"), "{}", r.summary());
    assert!(r.to_string().contains("empty (no faces)"));
}

#[test]
fn repair_drops_duplicates_and_degenerate_faces_and_winds_components() {
    let mut raw = tetra();
    // Vertex 4 on edge 0-1: the face (0, 4, 1) has zero area.
    raw.vertices.push(p(0.5, 0.0, 0.0));
    raw.faces.extend([[0, 4, 1], [1, 3, 0], [2, 2, 3]]);
    // A second tetrahedron with two of four faces reversed (a tie: the
    // first face's winding is kept).
    let n = raw.vertices.len();
    raw.vertices
        .extend(tetra().vertices.iter().map(|q| p(q.x + 3.0, q.y, q.z)));
    let mut t = tetra().faces;
    t[1].swap(1, 2);
    t[2].swap(1, 2);
    raw.faces
        .extend(t.iter().map(|f| [f[0] + n, f[1] + n, f[2] + n]));
    let m = Mesh::try_from(raw).unwrap();
    let plan = FaceRepair::plan(&m);
    assert_eq!(
        (
            plan.duplicate,
            plan.degenerate,
            plan.flipped,
            plan.unoriented
        ),
        (1, 2, 2, 0)
    );
    assert_eq!(
        plan.to_string(),
        "dropped 1 duplicate faces, dropped 2 zero-area or repeated-vertex faces, \
         reversed the winding of 2 faces (one winding per component)"
    );
    let fixed = m.with_faces(plan.faces.clone()).unwrap();
    // Left: the vertex only the zero-area face used, and two components.
    assert_eq!(
        kinds(&fixed),
        [
            DefectKind::SeveralComponents,
            DefectKind::UnreferencedVertices
        ]
    );
    assert_eq!(fixed.faces()[..4], tetra().faces[..]);
    // Nothing to repair on a clean mesh.
    assert!(!FaceRepair::plan(&icosphere(1)).changed());
}

#[test]
fn repair_reverses_the_minority_and_leaves_a_mobius_band() {
    let s = icosphere(1);
    let faces: Vec<Face> = s
        .faces()
        .iter()
        .enumerate()
        .map(|(i, &[a, b, c])| if i % 5 == 0 { [a, c, b] } else { [a, b, c] })
        .collect();
    let m = s.with_faces(faces).unwrap();
    let plan = FaceRepair::plan(&m);
    assert_eq!(plan.flipped, s.n_faces().div_ceil(5));
    assert_eq!(plan.faces, s.faces());
    // Möbius band (as in `mobius_strip_is_not_orientable`): left alone.
    let n = 12;
    let mut vertices = Vec::new();
    for i in 0..n {
        let u = std::f64::consts::TAU * i as f64 / n as f64;
        for s in [-0.3, 0.3] {
            let r = 1.0 + s * (u / 2.0).cos();
            vertices.push(p(r * u.cos(), r * u.sin(), s * (u / 2.0).sin()));
        }
    }
    let mut faces: Vec<Face> = Vec::new();
    for i in 0..n {
        let (a, b) = (2 * i, 2 * i + 1);
        let (c, d) = if i + 1 < n {
            (2 * i + 2, 2 * i + 3)
        } else {
            (1, 0)
        };
        faces.push([a, b, d]);
        faces.push([a, d, c]);
    }
    let band = Mesh::new(vertices, faces.clone()).unwrap();
    let plan = FaceRepair::plan(&band);
    assert_eq!((plan.flipped, plan.unoriented), (0, 1));
    assert_eq!(plan.faces, faces);
}

#[test]
fn policy_warns_refuses_or_repairs() {
    let m = tetra_mesh();
    let dup = m.with_faces([m.faces(), &[m.faces()[0]]].concat()).unwrap();
    let file = Path::new("dir/dup.ply");
    // Default: the mesh as it is, its defects listed.
    let c = DefectPolicy::default()
        .apply(dup.clone(), file, None)
        .unwrap();
    assert_eq!(c.mesh, dup);
    assert!(c.repair.is_none());
    assert_eq!(c.defects.len(), 3);
    // Strict: an error naming the file and every kind.
    let strict = DefectPolicy {
        strict: true,
        ..Default::default()
    };
    let e = strict
        .apply(dup.clone(), file, None)
        .unwrap_err()
        .to_string();
    for needle in [
        "dir/dup.ply",
        "1 duplicate faces",
        "non-manifold edges",
        "strict",
    ] {
        assert!(e.contains(needle), "{needle}: {e}");
    }
    // Repair (and strict): repaired, nothing left.
    let both = DefectPolicy {
        strict: true,
        repair: true,
    };
    let c = both.apply(dup.clone(), file, None).unwrap();
    assert_eq!(c.mesh, m);
    assert_eq!(c.repair.as_ref().map(|r| r.duplicate), Some(1));
    assert!(c.defects.is_empty());
    // A shared plan is used for a mesh with the planned face list only.
    let plan = FaceRepair::plan(&dup);
    let moved = dup.map_vertices(|q| p(2.0 * q.x, q.y, q.z)).unwrap();
    let c = both.apply(moved, file, Some((dup.faces(), &plan))).unwrap();
    assert_eq!(c.mesh.faces(), m.faces());
    let other = icosphere(0);
    let c = both
        .apply(other.clone(), file, Some((dup.faces(), &plan)))
        .unwrap();
    assert_eq!(c.mesh, other);
}

// ---- the commands ----

/// A small synthetic subject (2 subjects × 3 poses, 1.7k vertices).
fn synthetic() -> Vec<Vec<Mesh>> {
    FaustStyle {
        subjects: 2,
        poses: 3,
        resolution: 1,
        ..Default::default()
    }
    .generate()
    .unwrap()
    .meshes
}

/// `m` with its first `k` faces appended again (k duplicate faces).
fn duplicated(m: &Mesh, k: usize) -> Mesh {
    m.with_faces([m.faces(), &m.faces()[..k]].concat()).unwrap()
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn inspect_exits_non_zero_for_empty_meshes() {
    let d = tmp();
    let empty = write(d.path(), "empty.off", "OFF\n0 0 0\n");
    let cloud = write(d.path(), "cloud.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n");
    let good = d.path().join("tet.ply");
    write_ply(&good, &tetra_mesh()).unwrap();
    for (path, needle) in [
        (&empty, "EMPTY: no faces (0 vertices)"),
        (&cloud, "EMPTY: no faces (3 vertices)"),
    ] {
        for brief in [false, true] {
            let mut c = deformlab();
            c.arg("inspect");
            if brief {
                c.arg("--brief");
            }
            let o = c.arg(path).arg(&good).output().unwrap();
            let text = String::from_utf8_lossy(&o.stdout);
            assert_eq!(o.status.code(), Some(1), "{text}");
            assert!(text.contains(needle), "{text}");
            assert!(
                !text.contains(": clean\n") || text.matches(": clean").count() == 1,
                "{text}"
            );
            assert!(text.contains("1 empty or unusable"), "{text}");
        }
    }
    let o = deformlab().arg("inspect").arg(&good).output().unwrap();
    assert_eq!(o.status.code(), Some(0));
}

#[test]
fn keypoints_and_transfer_warn_refuse_and_repair() {
    let d = tmp();
    let set = synthetic();
    let a = d.path().join("a.ply");
    let a1 = d.path().join("a1.ply");
    let b = d.path().join("b.ply");
    write_ply(&a, &duplicated(&set[0][0], 3)).unwrap();
    write_ply(&a1, &duplicated(&set[0][1], 3)).unwrap();
    // The target: one face with a repeated vertex.
    let t = &set[1][0];
    write_ply(
        &b,
        &t.with_faces([t.faces(), &[[0, 0, 1]]].concat()).unwrap(),
    )
    .unwrap();
    let sel = |cmd: &str| -> Vec<String> {
        let mut v: Vec<String> = [cmd, "--source"].iter().map(|s| s.to_string()).collect();
        v.push(a.display().to_string());
        v.push("--deformed".into());
        v.push(a1.display().to_string());
        for s in [
            "--candidates",
            "8",
            "--max-keypoints",
            "3",
            "--epsilon",
            "0",
        ] {
            v.push(s.into());
        }
        v
    };
    // Default: one warning per file and kind, and a result.
    let o = ok(&sel("keypoints"));
    let err = stderr(&o);
    let warn: Vec<&str> = err.lines().filter(|l| l.starts_with("warning: ")).collect();
    // a, a1: duplicates, non-manifold edges and vertices.
    assert_eq!(warn.len(), 6, "{err}");
    assert!(
        warn.iter()
            .any(|l| l.contains("a.ply: 3 duplicate faces (first: ")),
        "{err}"
    );
    assert!(
        warn.iter().any(|l| l.contains("a1.ply: 3 duplicate faces")),
        "{err}"
    );
    // --strict: refused, naming the file.
    let mut args = sel("keypoints");
    args.push("--strict".into());
    let o = deformlab().args(&args).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(
        err.contains("a.ply") && err.contains("3 duplicate faces") && err.contains("strict"),
        "{err}"
    );
    // --repair: repaired and said so, no warning left; logged.
    let out = d.path().join("kp");
    let mut args = sel("keypoints");
    args.extend([
        "--repair".to_string(),
        "--out".into(),
        out.display().to_string(),
    ]);
    let o = ok(&args);
    let err = stderr(&o);
    assert!(!err.contains("warning:"), "{err}");
    let rep: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("repaired: "))
        .collect();
    assert_eq!(rep.len(), 2, "{err}");
    assert!(rep[0].contains("a.ply: dropped 3 duplicate faces"), "{err}");
    let log: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("log.json")).unwrap()).unwrap();
    assert_eq!(log["settings"]["repair"], true);
    assert_eq!(
        log["mesh_checks"].as_array().map(|a| a.len()),
        Some(2),
        "{log}"
    );

    // transfer: the target's defect is warned, and with --repair repaired.
    let mut args = sel("transfer");
    args.extend([
        "--target".to_string(),
        b.display().to_string(),
        "--same-connectivity".into(),
        "--out".into(),
        d.path().join("t1").display().to_string(),
    ]);
    let o = ok(&args);
    let err = stderr(&o);
    assert!(
        err.lines().any(|l| l.starts_with("warning: ")
            && l.contains("b.ply: 1 faces with a repeated vertex (first: ")),
        "{err}"
    );
    let log: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("t1/log.json")).unwrap())
            .unwrap();
    assert_eq!(
        log["mesh_checks"].as_array().map(|a| a.len()),
        Some(3),
        "{log}"
    );
    let mut args = sel("transfer");
    args.extend([
        "--target".to_string(),
        b.display().to_string(),
        "--same-connectivity".into(),
        "--repair".into(),
        "--strict".into(),
        "--out".into(),
        d.path().join("t2").display().to_string(),
    ]);
    let o = ok(&args);
    let err = stderr(&o);
    assert!(
        err.lines().any(|l| l.starts_with("repaired: ")
            && l.contains("b.ply: dropped 1 zero-area or repeated-vertex faces")),
        "{err}"
    );
    assert!(!err.contains("warning:"), "{err}");
}

const RUN: &str = r#"
name = "defects"
seed = 1

[dataset.faust]
path = "faust"

[cases]
sources = [0]
targets = [1]

[[methods]]
name = "identity"
kind = "identity"
"#;

#[test]
fn run_warns_records_refuses_and_repairs() {
    let d = tmp();
    let faust = d.path().join("faust");
    std::fs::create_dir_all(&faust).unwrap();
    for (s, poses) in synthetic().iter().enumerate() {
        for (p, m) in poses.iter().enumerate() {
            let path = faust.join(format!("tr_reg_{:03}.ply", 10 * s + p));
            if (s, p) == (0, 0) {
                write_ply(&path, &duplicated(m, 2)).unwrap();
            } else {
                write_ply(&path, m).unwrap();
            }
        }
    }
    let cfg = write(d.path(), "defects.toml", RUN);
    let run = |out: &str, extra: &[&str]| {
        let mut c = deformlab();
        c.arg("run")
            .arg(&cfg)
            .arg("--out")
            .arg(d.path().join(out))
            .arg("--no-plots");
        c.args(extra).output().unwrap()
    };
    // Default: warned once per kind, recorded, computed.
    let o = run("plain", &[]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let warn: Vec<&str> = err.lines().filter(|l| l.starts_with("warning: ")).collect();
    assert!(
        warn[0].starts_with("warning: tr_reg_000.ply: 2 duplicate faces (first: "),
        "{err}"
    );
    assert!(warn[1].contains("tr_reg_000.ply: ") && warn[1].contains("non-manifold edges"));
    assert!(warn[2].contains("tr_reg_000.ply: ") && warn[2].contains("non-manifold vertices"));
    assert_eq!(warn.len(), 3, "{err}");
    let dir = d.path().join("plain/defects");
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap();
    let notes = &m["mesh_defects"];
    assert_eq!(notes[0]["file"], "tr_reg_000.ply", "{notes}");
    assert_eq!(notes[0]["kind"], "duplicate_faces");
    assert_eq!(notes[0]["count"], 2);
    assert!(csv_rows(&dir.join("cases.csv"))
        .iter()
        .all(|r| r["status"] == "ok"));
    // A resumed run serves no mesh: no warning again.
    let o = run("plain", &[]);
    assert!(!stderr(&o).contains("warning:"), "{}", stderr(&o));

    // --strict: one error naming the file, before any case.
    let o = run("strict", &["--strict"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("tr_reg_000.ply: mesh: 2 duplicate faces"),
        "{err}"
    );
    assert!(!d.path().join("strict/defects/cases").exists());

    // --repair: repaired and said so; the config hash includes it.
    let o = run("repair", &["--repair", "--strict"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("warning:"), "{err}");
    assert!(
        err.lines()
            .any(|l| l == "repaired: tr_reg_000.ply: dropped 2 duplicate faces"),
        "{err}"
    );
    let m = std::fs::read_to_string(d.path().join("repair/defects/manifest.json")).unwrap();
    assert!(
        m.contains("tr_reg_000.ply: repaired: dropped 2 duplicate faces"),
        "{m}"
    );
    let o = run("plain", &["--repair"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("dataset.repair"), "{}", stderr(&o));
    // The same as the config key.
    let keyed = write(
        d.path(),
        "keyed.toml",
        RUN.replace(
            "[dataset.faust]",
            "[dataset]\nrepair = true\n\n[dataset.faust]",
        ),
    );
    let o = deformlab()
        .arg("run")
        .arg(&keyed)
        .arg("--out")
        .arg(d.path().join("repair"))
        .arg("--no-plots")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("defects: 0 computed"), "{out}");
}

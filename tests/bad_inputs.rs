//! The bad-input catalogue (issue 7): every way a user can hand deformlab
//! broken data, each with the clear error or the documented recovery it
//! gets. None may panic. Errors must name the file (or config key) and the
//! problem.
//!
//! | # | input | outcome |
//! |---|---|---|
//! | 1 | truncated PLY (ascii, binary), OFF, OBJ, .vert/.tri | error naming the file and where it ends |
//! | 2 | garbled PLY header / payload, OFF, OBJ, .vert/.tri, random bytes | error naming the file and the line/element |
//! | 3 | counts that disagree with the data (PLY, OFF) | error naming the file |
//! | 4 | face indices out of range (every format), negative, OBJ index 0 | error naming the file and the index |
//! | 5 | NaN / inf coordinates (every format) | `read_mesh` error naming the file and the vertex |
//! | 6 | zero-area faces | loaded; counted by the defect report; Laplacian and mass stay finite (recovery) |
//! | 7 | non-manifold edges / vertices | loaded; reported by the defect report and `inspect` (recovery) |
//! | 8 | inconsistently wound faces | loaded; reported (recovery) |
//! | 9 | a mesh set whose meshes differ in vertex count | error naming the vertex counts (library) and the file (CLI) |
//! | 10 | a BBW handle listed twice | error naming both handle slots and the vertex |
//! | 11 | more key points asked than candidates | recovery: the selection stops at the candidate count |
//! | 12 | an unreachable ε | recovery: stops at `max_keypoints`, reports its error (≥ ε) |
//! | 13 | isolated vertices (singular Laplacian/BBW/ARAP systems) | error naming the vertex / component |
//! | 14 | an empty partial shape (no target points for NICP / registration) | error |
//! | 15 | a correspondence file naming missing vertices | error naming the file and the pair |
//! | 16 | unknown config keys, wrong types | error naming the file, key and line |
//! | 17 | missing paths (mesh, config, dataset, correspondence) | error naming the path |
//! | 18 | regressions found by fuzzing (fuzz/) | error, no panic |
//! | 19 | empty files, a mesh without faces, a face with < 3 corners | error |

mod common;

use std::path::{Path, PathBuf};

use common::{cli_err, run as cli, tmp, write};
use deformlab::mesh::io::{parse_raw, parse_vert_tri, read_mesh, read_raw, write_ply, Format};
use deformlab::mesh::primitives::icosphere;
use deformlab::mesh::validate::DefectReport;
use deformlab::mesh::{Mesh, RawMesh};
use deformlab::{Error, Point};

/// Asserts an error whose message contains every needle (case-insensitive).
#[track_caller]
fn expect_err<T: std::fmt::Debug>(r: deformlab::Result<T>, needles: &[&str]) -> Error {
    let e = match r {
        Ok(v) => panic!("expected an error mentioning {needles:?}, got Ok({v:?})"),
        Err(e) => e,
    };
    let msg = e.to_string().to_lowercase();
    for n in needles {
        assert!(
            msg.contains(&n.to_lowercase()),
            "error {msg:?} does not mention {n:?}"
        );
    }
    e
}

/// Reads a mesh file, expecting an error naming the file and the needles.
#[track_caller]
fn read_err(path: &Path, needles: &[&str]) -> Error {
    let name = path.file_name().unwrap().to_str().unwrap().to_string();
    let mut all = vec![name.as_str()];
    all.extend_from_slice(needles);
    expect_err(read_mesh(path), &all)
}

fn p(x: f64, y: f64, z: f64) -> Point {
    Point::new(x, y, z)
}

const TET_V: [[f64; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
const TET_F: [[usize; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

fn ascii_ply(vertex_count: usize, face_count: usize, body: &str) -> String {
    format!(
        "ply\nformat ascii 1.0\nelement vertex {vertex_count}\nproperty float x\n\
         property float y\nproperty float z\nelement face {face_count}\n\
         property list uchar int vertex_indices\nend_header\n{body}"
    )
}

fn tet_body(faces: &[[usize; 3]]) -> String {
    let mut s = String::new();
    for v in TET_V {
        s += &format!("{} {} {}\n", v[0], v[1], v[2]);
    }
    for f in faces {
        s += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    s
}

fn binary_ply(vertex_count: u64, face_count: u64) -> Vec<u8> {
    let mut b = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {vertex_count}\n\
         property float x\nproperty float y\nproperty float z\nelement face {face_count}\n\
         property list uchar int vertex_indices\nend_header\n"
    )
    .into_bytes();
    for v in TET_V {
        for c in v {
            b.extend_from_slice(&(c as f32).to_le_bytes());
        }
    }
    for f in TET_F {
        b.push(3);
        for i in f {
            b.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    b
}

fn off_text(nv: &str, nf: usize, faces: &[[usize; 3]], coords: &[[&str; 3]]) -> String {
    let mut s = format!("OFF\n{nv} {nf} 0\n");
    for c in coords {
        s += &format!("{} {} {}\n", c[0], c[1], c[2]);
    }
    for f in faces {
        s += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    s
}

const TET_COORDS: [[&str; 3]; 4] = [
    ["0", "0", "0"],
    ["1", "0", "0"],
    ["0", "1", "0"],
    ["0", "0", "1"],
];

fn obj_text(coords: &[[&str; 3]], faces: &[&str]) -> String {
    let mut s = String::new();
    for c in coords {
        s += &format!("v {} {} {}\n", c[0], c[1], c[2]);
    }
    for f in faces {
        s += &format!("f {f}\n");
    }
    s
}

const TET_OBJ_FACES: [&str; 4] = ["1 3 2", "1 2 4", "1 4 3", "2 3 4"];

fn vert_tri(dir: &Path, name: &str, vert: &str, tri: &str) -> PathBuf {
    write(dir, &format!("{name}.tri"), tri);
    write(dir, &format!("{name}.vert"), vert)
}

const TET_VERT: &str = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
const TET_TRI: &str = "1 3 2\n1 2 4\n1 4 3\n2 3 4\n";

// ---------------------------------------------------------------------------
// 1. Truncated files.

#[test]
fn c01_truncated_files_of_every_format() {
    let d = tmp();
    let body = tet_body(&TET_F);
    let cut = &body[..body.len() / 2];
    read_err(
        &write(d.path(), "t.ply", ascii_ply(4, 4, cut)),
        &["element"],
    );
    let bin = binary_ply(4, 4);
    for keep in [bin.len() - 1, bin.len() - 13, bin.len() - 70] {
        read_err(&write(d.path(), "tb.ply", &bin[..keep]), &["element"]);
    }
    let off = off_text("4", 4, &TET_F, &TET_COORDS);
    let lines: Vec<&str> = off.lines().collect();
    read_err(
        &write(d.path(), "t.off", lines[..lines.len() - 2].join("\n")),
        &["face 2", "file ends after 2 of the 4 faces"],
    );
    read_err(
        &write(d.path(), "tl.off", &off[..off.len() - 4]),
        &["line 10", "face 3 announces 3 corners but lists 1"],
    );
    read_err(&write(d.path(), "header_only.off", "OFF\n"), &["counts"]);
    // OBJ has no counts: a file cut inside a line leaves a partial statement.
    let obj = obj_text(&TET_COORDS, &TET_OBJ_FACES);
    read_err(&write(d.path(), "t.obj", "v 0 0 0\nv 1 0"), &["line 2"]);
    read_err(
        &write(d.path(), "t2.obj", &obj[..obj.len() - 4]),
        &["at least 3"],
    );
    let v = vert_tri(d.path(), "tv", "0 0 0\n1 0 0\n0 1", TET_TRI);
    read_err(&v, &["line 3"]);
    let v = vert_tri(d.path(), "tt", TET_VERT, "1 3 2\n1 2");
    read_err(&v.with_extension("tri"), &["line 2", "found 2"]);
}

// 2. Garbled files.

#[test]
fn c02_garbled_files_of_every_format() {
    let d = tmp();
    let hdr = ascii_ply(4, 4, &tet_body(&TET_F)).replace("property float y", "propertyy float y");
    read_err(&write(d.path(), "h.ply", hdr), &["header", "propertyy"]);
    read_err(
        &write(d.path(), "f.ply", "ply\nformat klingon 1.0\nend_header\n"),
        &["header"],
    );
    read_err(
        &write(d.path(), "nv.ply", "ply\nformat ascii 1.0\nend_header\n"),
        &["vertex"],
    );
    let body = tet_body(&TET_F).replace("1 0 0", "1 zero 0");
    read_err(
        &write(d.path(), "b.ply", ascii_ply(4, 4, &body)),
        &["element 'vertex'"],
    );
    read_err(
        &write(
            d.path(),
            "g.off",
            "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n",
        ),
        &["line 4", "'x'"],
    );
    read_err(&write(d.path(), "k.off", "FFO\n3 1 0\n"), &["OFF", "FFO"]);
    read_err(&write(d.path(), "bin.off", "OFF BINARY\n"), &["binary"]);
    read_err(
        &write(d.path(), "g.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 two 3\n"),
        &["line 4", "two"],
    );
    read_err(
        &write(d.path(), "u.obj", [b'v', b' ', 0xff, 0xfe, b'\n']),
        &["line 1"],
    );
    let v = vert_tri(d.path(), "g", "0 0 0\n1 0 0\n0 1 0 7\n", "1 2 3\n");
    read_err(&v, &["g.vert", "more than 3"]);
    let v = vert_tri(d.path(), "gt", TET_VERT, "1 2 3 4\n");
    read_err(&v.with_extension("tri"), &["expected 3"]);
    // Random bytes under every extension: an error, never a panic.
    let mut x: u64 = 0x9e3779b97f4a7c15;
    for k in 0..50 {
        let bytes: Vec<u8> = (0..(k * 37 % 400))
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x >> 56) as u8
            })
            .collect();
        for ext in ["ply", "off", "obj"] {
            let path = write(d.path(), &format!("r.{ext}"), &bytes);
            let _ = read_mesh(&path);
        }
    }
}

// 3. Counts that disagree with the data.

#[test]
fn c03_counts_disagree_with_the_data() {
    let d = tmp();
    // Header announces more vertices / faces than present.
    read_err(
        &write(d.path(), "more.ply", ascii_ply(5, 4, &tet_body(&TET_F))),
        &["element"],
    );
    read_err(
        &write(d.path(), "moref.ply", ascii_ply(4, 6, &tet_body(&TET_F))),
        &["element 'face'"],
    );
    read_err(
        &write(d.path(), "moreb.ply", binary_ply(4, 5)),
        &["element 'face'"],
    );
    // A header announcing 4e9 elements fails at the end of the real data
    // (without reserving 4e9 slots first).
    read_err(
        &write(d.path(), "huge.ply", binary_ply(4_000_000_000, 4)),
        &["element"],
    );
    read_err(
        &write(d.path(), "hugef.ply", binary_ply(4, u32::MAX as u64)),
        &["element 'face'"],
    );
    read_err(
        &write(
            d.path(),
            "huge.off",
            off_text("4000000000", 4, &TET_F, &TET_COORDS),
        ),
        &["file ends after"],
    );
    // OFF: fewer than present (extra data) and more than present.
    read_err(
        &write(d.path(), "fewer.off", off_text("4", 3, &TET_F, &TET_COORDS)),
        &["unexpected data"],
    );
    read_err(
        &write(
            d.path(),
            "morefaces.off",
            off_text("4", 5, &TET_F, &TET_COORDS),
        ),
        &["face 4", "file ends after 4 of the 5 faces"],
    );
    // OFF polygon size larger than the corners listed.
    read_err(
        &write(
            d.path(),
            "poly.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n5 0 1 2\n",
        ),
        &["announces 5 corners but lists 3"],
    );
    read_err(
        &write(
            d.path(),
            "polymax.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n18446744073709551615 0 1 2\n",
        ),
        &["corners"],
    );
}

// 4. Indices out of range.

#[test]
fn c04_face_indices_out_of_range() {
    let d = tmp();
    let mut faces = TET_F;
    faces[2] = [0, 3, 9];
    read_err(
        &write(d.path(), "o.ply", ascii_ply(4, 4, &tet_body(&faces))),
        &["9"],
    );
    read_err(
        &write(
            d.path(),
            "neg.ply",
            ascii_ply(4, 1, &(tet_body(&[]) + "3 0 -1 2\n")),
        ),
        &["negative index -1"],
    );
    read_err(
        &write(d.path(), "o.off", off_text("4", 4, &faces, &TET_COORDS)),
        &["9"],
    );
    read_err(
        &write(d.path(), "o.obj", obj_text(&TET_COORDS, &["1 2 10"])),
        &["9"],
    );
    read_err(
        &write(d.path(), "z.obj", obj_text(&TET_COORDS, &["0 1 2"])),
        &["line 5", "index 0"],
    );
    read_err(
        &write(d.path(), "n.obj", obj_text(&TET_COORDS, &["-5 1 2"])),
        &["-5"],
    );
    read_err(
        &write(
            d.path(),
            "m.obj",
            obj_text(&TET_COORDS, &["-9223372036854775808 1 2"]),
        ),
        &["-9223372036854775808"],
    );
    let v = vert_tri(d.path(), "o", TET_VERT, "1 2 99\n");
    read_err(&v, &["98"]);
    let v = vert_tri(d.path(), "z", TET_VERT, "0 1 2\n");
    read_err(&v.with_extension("tri"), &["line 1", "one-based"]);
    // The raw reader keeps the bad index for the defect report.
    let raw = read_raw(&d.path().join("o.off")).unwrap();
    assert_eq!(DefectReport::of(&raw).out_of_range_faces.count, 1);
    // The library constructor refuses it too.
    expect_err(Mesh::new(vec![p(0., 0., 0.); 3], vec![[0, 1, 3]]), &["3"]);
}

// 5. NaN / inf coordinates.

#[test]
fn c05_nan_and_inf_coordinates() {
    let d = tmp();
    for (name, bad) in [("nan", "nan"), ("inf", "inf"), ("ninf", "-inf")] {
        // ASCII PLY numbers are parsed by ply-rs-bw, which does not accept
        // nan/inf spellings: an error naming the element and the line.
        let body = tet_body(&TET_F).replacen("1 0 0", &format!("1 {bad} 0"), 1);
        read_err(
            &write(d.path(), &format!("{name}.ply"), ascii_ply(4, 4, &body)),
            &["element 'vertex'", "line 11"],
        );
        let mut c = TET_COORDS;
        c[1][1] = bad;
        read_err(
            &write(
                d.path(),
                &format!("{name}.off"),
                off_text("4", 4, &TET_F, &c),
            ),
            &["vertex 1"],
        );
        read_err(
            &write(
                d.path(),
                &format!("{name}.obj"),
                obj_text(&c, &TET_OBJ_FACES),
            ),
            &["vertex 1"],
        );
        let v = vert_tri(
            d.path(),
            name,
            &TET_VERT.replacen("1 0 0", &format!("1 {bad} 0"), 1),
            TET_TRI,
        );
        read_err(&v, &["vertex 1"]);
    }
    // Binary PLY with a NaN float.
    let mut b = binary_ply(4, 4);
    let hdr_len = b.len() - 4 * 12 - 4 * 13;
    b[hdr_len + 12..hdr_len + 16].copy_from_slice(&f32::NAN.to_le_bytes());
    read_err(&write(d.path(), "nanb.ply", &b), &["vertex 1"]);
    expect_err(
        Mesh::new(
            vec![p(0., 0., 0.), p(f64::NAN, 0., 0.), p(0., 1., 0.)],
            vec![[0, 1, 2]],
        ),
        &["vertex 1"],
    );
    // Moving a valid mesh to non-finite positions is refused as well.
    let m = icosphere(1);
    let mut v = m.vertices().to_vec();
    v[5].z = f64::INFINITY;
    expect_err(m.with_vertices(v), &["vertex 5"]);
}

// 6. Zero-area faces.

#[test]
fn c06_zero_area_faces_are_reported_and_operators_stay_finite() {
    use deformlab::ops::{cotan_laplacian, mass_matrix, MassKind};
    // A tetrahedron plus a sliver: vertex 4 on edge (0, 1), face (0, 4, 1)
    // has zero area; vertex 5 duplicates vertex 2 (a collapsed face).
    let mut v: Vec<Point> = TET_V.iter().map(|c| p(c[0], c[1], c[2])).collect();
    v.push(p(0.5, 0.0, 0.0));
    let mut f = TET_F.to_vec();
    f.push([0, 4, 1]);
    let raw = RawMesh {
        vertices: v.clone(),
        faces: f.clone(),
    };
    let report = DefectReport::of(&raw);
    assert_eq!(
        report.zero_area_faces.first,
        vec![4],
        "{}",
        report.summary()
    );
    // Documented recovery: the mesh loads; the cotan Laplacian and the mass
    // matrix have no NaN or inf (degenerate corners contribute nothing).
    let m = Mesh::new(v, f).unwrap();
    let l = cotan_laplacian(&m);
    assert!(l.values().iter().all(|x| x.is_finite()));
    assert!(mass_matrix(&m, MassKind::Voronoi)
        .iter()
        .all(|x| x.is_finite()));
    // From a file: loads, and `inspect` names the defect.
    let d = tmp();
    let path = d.path().join("sliver.ply");
    write_ply(&path, &m).unwrap();
    assert_eq!(read_mesh(&path).unwrap().n_faces(), 5);
    let o = cli(&["inspect", path.to_str().unwrap()]);
    let out = String::from_utf8_lossy(&o.stdout).to_lowercase();
    assert!(out.contains("zero"), "{out}");
}

// 7. Non-manifold meshes.

#[test]
fn c07_non_manifold_meshes_are_reported() {
    // Three triangles on one edge (0, 1).
    let v = vec![
        p(0., 0., 0.),
        p(1., 0., 0.),
        p(0.5, 1., 0.),
        p(0.5, -1., 0.),
        p(0.5, 0., 1.),
    ];
    let f = vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]];
    let r = DefectReport::of(&RawMesh {
        vertices: v.clone(),
        faces: f.clone(),
    });
    assert_eq!(r.non_manifold_edges.count, 1, "{}", r.summary());
    // Bow tie: two triangles sharing only vertex 0.
    let bow = RawMesh {
        vertices: vec![
            p(0., 0., 0.),
            p(1., 0., 0.),
            p(1., 1., 0.),
            p(-1., 0., 0.),
            p(-1., -1., 0.),
        ],
        faces: vec![[0, 1, 2], [0, 3, 4]],
    };
    let r = DefectReport::of(&bow);
    assert_eq!(r.non_manifold_vertices.first, vec![0], "{}", r.summary());
    // Recovery: loads, operators work, and `inspect` reports the defect.
    let m = Mesh::new(v, f).unwrap();
    let w = deformlab::skin::bbw::bounded_biharmonic_weights(
        &m,
        &[2, 3],
        &deformlab::skin::bbw::BbwOptions::default(),
    );
    // Vertex 4 is a free vertex, 0 and 1 connect everything: weights exist
    // and are a partition of unity, or a clear error.
    match w {
        Ok(w) => {
            for i in 0..w.nrows() {
                let s: f64 = w.row(i).sum();
                assert!((s - 1.0).abs() < 1e-6, "row {i} sums to {s}");
            }
        }
        Err(e) => assert!(!e.to_string().is_empty()),
    }
    let d = tmp();
    let path = d.path().join("fin.ply");
    write_ply(&path, &m).unwrap();
    let o = cli(&["inspect", path.to_str().unwrap()]);
    let out = String::from_utf8_lossy(&o.stdout).to_lowercase();
    assert!(
        out.contains("non-manifold") || out.contains("nonmanifold"),
        "{out}"
    );
}

// 8. Inconsistently wound meshes.

#[test]
fn c08_inconsistent_winding_is_reported() {
    let mut f = TET_F;
    f[3] = [1, 3, 2]; // flipped
    let raw = RawMesh {
        vertices: TET_V.iter().map(|c| p(c[0], c[1], c[2])).collect(),
        faces: f.to_vec(),
    };
    let r = DefectReport::of(&raw);
    assert!(!r.inconsistent_edges.is_empty(), "{}", r.summary());
    assert!(!r.is_clean());
    // Recovery: it loads (winding is not needed by the cotan operators).
    let d = tmp();
    let path = write(d.path(), "flip.off", off_text("4", 4, &f, &TET_COORDS));
    assert_eq!(read_mesh(&path).unwrap().n_faces(), 4);
}

// 9. A mesh set whose meshes differ in vertex count.

fn bent(m: &Mesh, k: f64) -> Mesh {
    m.map_vertices(|q| {
        let a = k * q.z.max(0.0);
        p(
            q.x * a.cos() - q.y * a.sin(),
            q.x * a.sin() + q.y * a.cos(),
            q.z,
        )
    })
    .unwrap()
}

fn fast_opts() -> deformlab::transfer::KeypointOptions {
    deformlab::transfer::KeypointOptions {
        n_candidates: 8,
        max_keypoints: 4,
        mode: deformlab::transfer::SelectionMode::Fast,
        max_swap_passes: 0,
        fps: deformlab::ops::FpsMetric::Euclidean,
        ..Default::default()
    }
}

#[test]
fn c09_mesh_set_with_different_vertex_counts() {
    use deformlab::transfer::select_keypoints;
    let a = icosphere(2);
    let other = icosphere(1);
    expect_err(
        select_keypoints(&a, &[bent(&a, 0.5), other.clone()], &fast_opts()),
        &[&a.n_vertices().to_string(), &other.n_vertices().to_string()],
    );
    // Through the CLI the error names the file.
    let d = tmp();
    let (pa, pb) = (d.path().join("a.ply"), d.path().join("b.ply"));
    write_ply(&pa, &a).unwrap();
    write_ply(&pb, &other).unwrap();
    cli_err(
        &[
            "keypoints",
            "--source",
            pa.to_str().unwrap(),
            "--deformed",
            pb.to_str().unwrap(),
            "--candidates",
            "8",
        ],
        &["b.ply"],
    );
}

// 10. A BBW handle listed twice.

#[test]
fn c10_bbw_handle_listed_twice() {
    use deformlab::skin::bbw::{bounded_biharmonic_weights, BbwOptions, WeightMode};
    let m = icosphere(2);
    for mode in [WeightMode::PerHandle, WeightMode::Coupled] {
        expect_err(
            bounded_biharmonic_weights(&m, &[3, 17, 3], &BbwOptions::with_mode(mode)),
            &["handles 0 and 2", "vertex 3", "distinct"],
        );
    }
    expect_err(
        bounded_biharmonic_weights(&m, &[3, 9999], &BbwOptions::default()),
        &["9999"],
    );
    expect_err(
        bounded_biharmonic_weights(&m, &[], &BbwOptions::default()),
        &["handle"],
    );
    // User key points given twice to the transfer CLI.
    let d = tmp();
    let pa = d.path().join("a.ply");
    let pb = d.path().join("a1.ply");
    write_ply(&pa, &m).unwrap();
    write_ply(&pb, &bent(&m, 0.5)).unwrap();
    let kp = write(d.path(), "kp.csv", "source\n3\n17\n3\n");
    let out = d.path().join("out");
    cli_err(
        &[
            "transfer",
            "--source",
            pa.to_str().unwrap(),
            "--deformed",
            pb.to_str().unwrap(),
            "--target",
            pa.to_str().unwrap(),
            "--same-connectivity",
            "--keypoints",
            kp.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &["3"],
    );
}

// 11–12. Key point selection: more key points than candidates, unreachable ε.

#[test]
fn c11_c12_more_keypoints_than_candidates_and_unreachable_epsilon() {
    use deformlab::transfer::select_keypoints;
    let a = icosphere(2);
    let deformed = [bent(&a, 0.8), bent(&a, -0.6)];
    let opts = deformlab::transfer::KeypointOptions {
        n_candidates: 5,
        max_keypoints: 12,
        epsilon: 0.0, // unreachable: the error is never < 0
        ..fast_opts()
    };
    let s = select_keypoints(&a, &deformed, &opts).unwrap();
    // Recovery: at most n_candidates key points, all distinct candidates.
    assert_eq!(s.keypoints.len(), 5, "{:?}", s.keypoints);
    let mut k = s.keypoints.clone();
    k.sort();
    k.dedup();
    assert_eq!(k.len(), 5);
    assert!(s.keypoints.iter().all(|x| s.candidates.contains(x)));
    // Recovery for an unreachable ε: stops at max_keypoints with its error.
    let opts = deformlab::transfer::KeypointOptions {
        n_candidates: 8,
        max_keypoints: 3,
        epsilon: 0.0,
        ..fast_opts()
    };
    let s = select_keypoints(&a, &deformed, &opts).unwrap();
    assert_eq!(s.keypoints.len(), 3);
    assert!(s.error.is_finite() && s.error >= 0.0);
    assert!(s.trace.iter().all(|t| t.error >= opts.epsilon));
    // Invalid values are errors, not recoveries.
    let bad = |o: deformlab::transfer::KeypointOptions, needle: &str| {
        expect_err(select_keypoints(&a, &deformed, &o), &[needle]);
    };
    bad(
        deformlab::transfer::KeypointOptions {
            n_candidates: 0,
            ..fast_opts()
        },
        "n_candidates",
    );
    bad(
        deformlab::transfer::KeypointOptions {
            n_candidates: 10_000,
            ..fast_opts()
        },
        "n_candidates",
    );
    bad(
        deformlab::transfer::KeypointOptions {
            max_keypoints: 0,
            ..fast_opts()
        },
        "max_keypoints",
    );
    bad(
        deformlab::transfer::KeypointOptions {
            epsilon: f64::NAN,
            ..fast_opts()
        },
        "epsilon",
    );
    bad(
        deformlab::transfer::KeypointOptions {
            epsilon: -1.0,
            ..fast_opts()
        },
        "epsilon",
    );
    expect_err(select_keypoints(&a, &[], &fast_opts()), &["deformed"]);
    // The config refuses a non-positive count with the key named.
    let text = CONFIG_OK.replace("max_keypoints = 3", "max_keypoints = 0");
    expect_err(
        deformlab::experiment::parse_config(&text, Path::new("/tmp/k.toml")),
        &["k.toml", "max_keypoints"],
    );
}

// 13. Isolated vertices: singular systems.

#[test]
fn c13_isolated_vertices_make_clear_errors() {
    use deformlab::ops::{cotan_laplacian, mass_matrix, MassKind};
    use deformlab::skin::bbw::{BbwOptions, Biharmonic};
    let m = icosphere(2);
    let mut v = m.vertices().to_vec();
    v.push(p(3.0, 0.0, 0.0)); // isolated: in no face
    let iso = Mesh::new(v, m.faces().to_vec()).unwrap();
    let n = iso.n_vertices();
    let r = DefectReport::of_mesh(&iso);
    assert_eq!(r.unreferenced_vertices.first, vec![n - 1]);
    // Laplacian: a zero row and column, zero mass. L + εM (the system of
    // heat geodesics and of every Laplacian smoothing) is singular there:
    // the factorisation says so instead of returning garbage.
    let l = cotan_laplacian(&iso);
    let mass = mass_matrix(&iso, MassKind::Voronoi);
    assert_eq!(mass[n - 1], 0.0);
    let mut trip = Vec::new();
    for (i, j, x) in l.triplet_iter() {
        trip.push((i, j, *x));
    }
    for (i, m) in mass.iter().enumerate() {
        trip.push((i, i, 1e-3 * m));
    }
    let coo = nalgebra_sparse::CooMatrix::try_from_triplets(
        n,
        n,
        trip.iter().map(|t| t.0).collect(),
        trip.iter().map(|t| t.1).collect(),
        trip.iter().map(|t| t.2).collect(),
    )
    .unwrap();
    let a = nalgebra_sparse::CscMatrix::from(&coo);
    let chol = deformlab::solve::SparseCholesky::new(&a);
    expect_err(chol.map(|_| ()), &["positive definite"]);
    // BBW: the biharmonic operator needs M⁻¹.
    expect_err(
        Biharmonic::new(&iso).map(|_| ()),
        &[&format!("vertex {}", n - 1), "isolated"],
    );
    // Two components, handles in one only: singular, the component is named.
    let two = {
        let t = icosphere(1);
        let k = t.n_vertices();
        let mut v = t.vertices().to_vec();
        v.extend(t.vertices().iter().map(|q| p(q.x + 5.0, q.y, q.z)));
        let mut f = t.faces().to_vec();
        f.extend(t.faces().iter().map(|f| [f[0] + k, f[1] + k, f[2] + k]));
        Mesh::new(v, f).unwrap()
    };
    expect_err(
        deformlab::skin::bbw::bounded_biharmonic_weights(&two, &[0, 1], &BbwOptions::default()),
        &["component", "no handle"],
    );
    // ARAP (reduced) over the isolated vertex: a clear error or finite
    // results, never NaN.
    let w = nalgebra::DMatrix::from_fn(n, 2, |i, j| if (i % 2) == j { 1.0 } else { 0.0 });
    match deformlab::arap::ReducedArap::new(&iso, &w, &vec![0; n], Default::default()) {
        Ok(arap) => match arap.solve(iso.vertices(), None) {
            Ok(sol) => assert!(
                sol.positions
                    .iter()
                    .all(|q| q.iter().all(|x| x.is_finite())),
                "ARAP returned non-finite positions"
            ),
            Err(e) => assert!(!e.to_string().is_empty()),
        },
        Err(e) => assert!(!e.to_string().is_empty()),
    }
    // Key point selection on a mesh with an isolated vertex: a clear error.
    let deformed = [bent(&iso, 0.5)];
    expect_err(
        deformlab::transfer::select_keypoints(&iso, &deformed, &fast_opts()),
        &[&format!("vertex {}", n - 1)],
    );
}

// 14. An empty partial shape.

#[test]
fn c14_empty_partial_shape() {
    use deformlab::data::partial::{make_partial, PartialOptions};
    use deformlab::register::*;
    // A partial shape with nothing in it cannot even be a mesh.
    expect_err(Mesh::new(Vec::new(), Vec::new()), &["no faces"]);
    let meshes = synthetic_class(1, 0).unwrap();
    // Asking the generator to keep nothing is refused.
    let opts = PartialOptions {
        keep_fraction: (0.0, 0.0),
        min_fraction: 0.0,
        ..Default::default()
    };
    expect_err(
        make_partial(&meshes[2], &[0], &opts).map(|_| ()),
        &["keep_fraction"],
    );
    let examples = vec![meshes[1].clone(), meshes[3].clone()];
    let setup = build(&examples, &FbtConfig::default()).unwrap();
    let params = FbtParams::default();
    // Registration with no target points at all (zero constraint rows).
    let rows: ConstraintRows = Vec::new();
    let y = nalgebra::DMatrix::<f64>::zeros(0, 3);
    match setup.pipeline.systems(&rows, &params) {
        Err(e) => assert!(e.to_string().contains("constraint"), "{e}"),
        Ok(sys) => {
            // Used to return α = 0 and every vertex at one point.
            expect_err(
                sys.solve(&y, &Schedule::default()).map(|_| ()),
                &["no constraint rows", "no points"],
            );
        }
    }
    // NICP without features whose target is out of reach (no point within
    // the distance bound): no target points to match.
    let some = vertex_rows(&[0, 10, 20]);
    let fy = apply_rows(&some, examples[1].vertices()).unwrap();
    let reg = setup
        .pipeline
        .systems(&some, &params)
        .unwrap()
        .solve(&fy, &Schedule::default())
        .unwrap();
    let feats: ConstraintRows = Vec::new();
    let far = meshes[2]
        .map_vertices(|q| p(q.x + 100.0, q.y, q.z))
        .unwrap();
    expect_err(
        nicp(
            setup.pipeline.last(),
            &params,
            (&feats, &y),
            &far,
            &reg.t,
            reg.alpha,
            &NicpOptions::default(),
        )
        .map(|_| ()),
        &["no"],
    );
}

// 15. A correspondence file naming missing vertices.

#[test]
fn c15_correspondence_naming_missing_vertices() {
    use deformlab::data::correspondence::{check_pairs, read_pairs, PairFormat};
    let d = tmp();
    let f = write(d.path(), "markers.csv", "source,target\n0,1\n5,99999\n");
    let pairs = read_pairs(&f, PairFormat::Csv, None).unwrap();
    expect_err(
        check_pairs(&f, &pairs, 162, 162),
        &["markers.csv", "pair 1", "99999"],
    );
    expect_err(
        read_pairs(&write(d.path(), "neg.csv", "0,-1\n"), PairFormat::Csv, None).map(|_| ()),
        &["neg.csv", "line 1"],
    );
    expect_err(
        read_pairs(
            &write(d.path(), "c.cons", "3\n1, 2\n"),
            PairFormat::Cons,
            None,
        )
        .map(|_| ()),
        &["c.cons"],
    );
    expect_err(
        read_pairs(&d.path().join("absent.csv"), PairFormat::Csv, None).map(|_| ()),
        &["absent.csv"],
    );
    // Through the transfer CLI.
    let m = icosphere(2);
    let (pa, pb) = (d.path().join("a.ply"), d.path().join("a1.ply"));
    write_ply(&pa, &m).unwrap();
    write_ply(&pb, &bent(&m, 0.5)).unwrap();
    let out = d.path().join("out");
    cli_err(
        &[
            "transfer",
            "--source",
            pa.to_str().unwrap(),
            "--deformed",
            pb.to_str().unwrap(),
            "--target",
            pa.to_str().unwrap(),
            "--correspondence",
            f.to_str().unwrap(),
            "--candidates",
            "4",
            "--out",
            out.to_str().unwrap(),
        ],
        &["markers.csv", "99999"],
    );
}

// 16. Unknown config keys and wrong types.

const CONFIG_OK: &str = r#"
name = "tiny"
[dataset.synthetic]
subjects = 2
poses = 2
[defaults]
mode = "fast"
n_candidates = 8
max_keypoints = 3
[[methods]]
name = "auto"
kind = "bdt"
"#;

#[test]
fn c16_unknown_config_keys_and_wrong_types() {
    use deformlab::experiment::parse_config;
    let path = Path::new("/tmp/cfg/bad.toml");
    parse_config(CONFIG_OK, path).unwrap();
    let e = expect_err(
        parse_config(
            &CONFIG_OK.replace("n_candidates = 8", "n_candidate = 8"),
            path,
        ),
        &["bad.toml", "n_candidate", "line 8"],
    );
    let _ = e;
    expect_err(
        parse_config(&(CONFIG_OK.to_string() + "\n[oops]\nx = 1\n"), path),
        &["bad.toml", "oops"],
    );
    expect_err(
        parse_config(&CONFIG_OK.replace("poses = 2", "poses = \"two\""), path),
        &["bad.toml", "poses"],
    );
    expect_err(
        parse_config(
            &CONFIG_OK.replace("kind = \"bdt\"", "kind = \"bdtt\""),
            path,
        ),
        &["bad.toml", "bdtt"],
    );
    expect_err(parse_config("name = \n[[", path), &["bad.toml", "line 1"]);
    // Through the CLI: the file and the key.
    let d = tmp();
    let cfg = write(
        d.path(),
        "typo.toml",
        CONFIG_OK.replace("max_keypoints", "max_keypoint"),
    );
    let out = d.path().join("out");
    cli_err(
        &["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()],
        &["typo.toml", "max_keypoint"],
    );
}

// 17. Missing paths.

#[test]
fn c17_missing_paths() {
    let d = tmp();
    let missing = d.path().join("nowhere.ply");
    read_err(&missing, &[]);
    read_err(&d.path().join("gone.off"), &[]);
    // A .vert without its .tri.
    write(d.path(), "lonely.vert", TET_VERT);
    read_err(&d.path().join("lonely.vert"), &["lonely.tri", "missing"]);
    read_err(&write(d.path(), "x.stl", "solid"), &["unknown mesh format"]);
    // Config naming a missing dataset folder.
    let cfg = "name = \"m\"\n[dataset.faust]\npath = \"no/such/folder\"\n[[methods]]\nname = \"a\"\nkind = \"bdt\"\n";
    let cfg_path = write(d.path(), "m.toml", cfg);
    expect_err(
        deformlab::experiment::load_config(&cfg_path)
            .and_then(|l| deformlab::experiment::Collection::open(&l).map(|_| ())),
        &["no/such/folder"],
    );
    // CLI: missing config, missing mesh.
    let out = d.path().join("out");
    cli_err(
        &[
            "run",
            "/nonexistent/suite.toml",
            "--out",
            out.to_str().unwrap(),
        ],
        &["suite.toml"],
    );
    cli_err(&["inspect", missing.to_str().unwrap()], &["nowhere.ply"]);
    cli_err(
        &[
            "keypoints",
            "--source",
            missing.to_str().unwrap(),
            "--deformed",
            missing.to_str().unwrap(),
        ],
        &["nowhere.ply"],
    );
}

// 18. Regressions found by fuzzing (fuzz/; inputs that once panicked,
// hung or allocated without bound).

#[test]
fn c18_fuzz_regressions() {
    let name = Path::new("fuzz");
    // (format, bytes, a word the error must contain)
    let cases: Vec<(Format, Vec<u8>, &str)> = vec![
        // A binary list announcing 255 corners with 3 present.
        (
            Format::Ply,
            {
                let mut b = binary_ply(4, 1);
                let l = b.len();
                b.truncate(l - 3 * 13);
                let k = b.len() - 13;
                b[k] = 255;
                b
            },
            "element",
        ),
        (
            Format::Off,
            b"OFF\n1 1 0\n0 0 0\n18446744073709551615 0 0 0\n".to_vec(),
            "corners",
        ),
        (
            Format::Obj,
            b"v 0 0 0\nf -9223372036854775808 1 1\n".to_vec(),
            "index",
        ),
    ];
    for (format, bytes, needle) in cases {
        expect_err(parse_raw(format, &bytes, name), &["fuzz", needle]);
    }
    expect_err(
        parse_vert_tri(b"0 0 0\n", b"1e300 1 1\n", name),
        &["fuzz.tri"],
    );
    // Config: a syntax error on a line whose key follows a multi-byte
    // character ('‖') made the key lookup slice inside that character
    // (found by the `config` target after 68 779 executions).
    let text = std::str::from_utf8(include_bytes!("data/fuzz/config_char_boundary.toml")).unwrap();
    expect_err(
        deformlab::experiment::parse_config(text, Path::new("fuzz.toml")),
        &["fuzz.toml", "line"],
    );
}

// 19. Empty files, no faces, degenerate polygons.

#[test]
fn c19_empty_files_and_degenerate_polygons() {
    let d = tmp();
    for ext in ["ply", "off", "obj"] {
        read_err(&write(d.path(), &format!("empty.{ext}"), ""), &[]);
    }
    let v = vert_tri(d.path(), "empty", "", "");
    read_err(&v, &[]);
    read_err(
        &write(
            d.path(),
            "two.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
        ),
        &["at least 3"],
    );
    read_err(
        &write(d.path(), "two.obj", obj_text(&TET_COORDS, &["1 2"])),
        &["at least 3"],
    );
    read_err(
        &write(
            d.path(),
            "two.ply",
            ascii_ply(4, 1, &(tet_body(&[]) + "2 0 1\n")),
        ),
        &["at least 3"],
    );
    // A point cloud (no faces) as a mesh file.
    read_err(
        &write(d.path(), "cloud.obj", obj_text(&TET_COORDS, &[])),
        &["face"],
    );
}

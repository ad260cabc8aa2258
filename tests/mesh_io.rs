//! Mesh readers and writers: round trips, hand-made files in every accepted
//! variant, malformed inputs (errors, never panics) and the real data.

mod common;

use std::path::{Path, PathBuf};

use common::{tmp, write};
use deformlab::data::shared_data_or_skip;
use deformlab::mesh::io::{read_mesh, read_raw, write_obj, write_ply};
use deformlab::mesh::primitives::{icosphere, torus};
use deformlab::mesh::{Face, Mesh, RawMesh};
use deformlab::Point;

/// A small mesh with coordinates that do not have short decimal forms.
fn awkward_mesh() -> Mesh {
    torus(1.0 / 3.0, 0.1, 7, 5)
        .map_vertices(|p| Point::new(p.x * 1e-7 + 1.0 / 7.0, p.y * 1e12, -p.z))
        .unwrap()
}

fn tetra() -> RawMesh {
    RawMesh {
        vertices: vec![
            Point::new(0.0, 0.0, 0.0),
            Point::new(1.0, 0.0, 0.0),
            Point::new(0.0, 1.0, 0.0),
            Point::new(0.0, 0.0, 1.5),
        ],
        faces: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    }
}

/// Asserts that `r` is an error whose message names the file and contains
/// every one of `needles`.
fn assert_err<T: std::fmt::Debug>(r: deformlab::Result<T>, path: &Path, needles: &[&str]) {
    let e = r.expect_err("expected an error");
    let msg = e.to_string();
    let name = path.file_name().unwrap().to_str().unwrap();
    assert!(msg.contains(name), "error does not name {name}: {msg}");
    for n in needles {
        assert!(msg.contains(n), "error lacks '{n}': {msg}");
    }
}

// ---------------------------------------------------------------- round trips

#[test]
fn ply_round_trip_is_exact() {
    let d = tmp();
    for mesh in [icosphere(2), awkward_mesh()] {
        let p = d.path().join("m.ply");
        write_ply(&p, &mesh).unwrap();
        assert_eq!(read_mesh(&p).unwrap(), mesh);
    }
    // No temporary file left behind.
    let names: Vec<_> = std::fs::read_dir(d.path()).unwrap().collect();
    assert_eq!(names.len(), 1);
}

#[test]
fn off_round_trip_is_exact() {
    let d = tmp();
    for mesh in [icosphere(2), awkward_mesh()] {
        let p = d.path().join("m.off");
        deformlab::mesh::io::write_off(&p, &mesh).unwrap();
        assert_eq!(read_mesh(&p).unwrap(), mesh);
    }
}

#[test]
fn obj_round_trip_is_exact() {
    let d = tmp();
    for mesh in [icosphere(1), awkward_mesh()] {
        let p = d.path().join("m.obj");
        write_obj(&p, &mesh).unwrap();
        assert_eq!(read_mesh(&p).unwrap(), mesh);
    }
    let tiny = Mesh::new(
        vec![
            Point::new(1e-300, -2.5e300, 0.1),
            Point::new(0.0, 1.0, 0.0),
            Point::new(1.0, 0.0, -0.0),
        ],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let p = d.path().join("tiny.obj");
    write_obj(&p, &tiny).unwrap();
    assert_eq!(read_mesh(&p).unwrap(), tiny);
}

#[test]
fn off_hand_made_round_trip() {
    let d = tmp();
    let t = tetra();
    let mut s = String::from("OFF\n# a comment\n\n4 4 6\n");
    for v in &t.vertices {
        s += &format!("{} {} {}   # trailing comment\n", v.x, v.y, v.z);
    }
    for f in &t.faces {
        s += &format!("3 {} {} {} 255 0 0\n", f[0], f[1], f[2]);
    }
    let p = write(d.path(), "t.off", &s);
    assert_eq!(read_raw(&p).unwrap(), t);

    // Counts on the keyword line, COFF vertex colours, a quad.
    let s = "COFF 4 1 0\n0 0 0 1 0 0 1\n1 0 0 1 0 0 1\n1 1 0 0 1 0 1\n0 1 0 0 0 1 1\n4 0 1 2 3\n";
    let p = write(d.path(), "quad.off", s);
    let r = read_raw(&p).unwrap();
    assert_eq!(r.vertices.len(), 4);
    assert_eq!(r.faces, vec![[0, 1, 2], [0, 2, 3]]);

    // NOFF: normals after the position.
    let s = "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n";
    let p = write(d.path(), "n.off", s);
    assert_eq!(read_raw(&p).unwrap().faces, vec![[0, 1, 2]]);
}

#[test]
fn obj_hand_made_variants() {
    let d = tmp();
    let s = "\
# comment
mtllib x.mtl
o thing
v 0 0 0
v 1 0 0 1.0
v 1 1 0 0.5 0.5 0.5
v 0 1 0
vn 0 0 1
vt 0 0
g group
usemtl m
s off
f 1//1 2//1 3//1
f 1/1/1 3/1/1 4/1/1
f 1/1 2/1 3/1
f -4 -3 -2 -1
l 1 2
";
    let p = write(d.path(), "v.obj", s);
    let r = read_raw(&p).unwrap();
    assert_eq!(r.vertices.len(), 4);
    assert_eq!(r.vertices[2], Point::new(1.0, 1.0, 0.0));
    let want: Vec<Face> = vec![[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 1, 2], [0, 2, 3]];
    assert_eq!(r.faces, want);

    // Relative indices refer to the vertices defined so far.
    let s = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf -4 -1 -2\n";
    let p = write(d.path(), "rel.obj", s);
    assert_eq!(read_raw(&p).unwrap().faces, vec![[0, 1, 2], [0, 3, 2]]);
}

#[test]
fn vert_tri_pair() {
    let d = tmp();
    let t = tetra();
    let mut v = String::new();
    for p in &t.vertices {
        v += &format!("{} {} {}\n", p.x, p.y, p.z);
    }
    let mut tri = String::new();
    for f in &t.faces {
        tri += &format!("{} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    let pv = write(d.path(), "cat0.vert", v);
    let pt = write(d.path(), "cat0.tri", tri);
    assert_eq!(read_raw(&pv).unwrap(), t);
    assert_eq!(read_raw(&pt).unwrap(), t);
}

// ------------------------------------------------------------ PLY by hand

/// One appender per number type, in the file's byte order.
macro_rules! bin_writers {
    ($($t:ident),*) => {
        $(
            fn $t(&mut self, x: $t) -> &mut Self {
                let b = if self.be { x.to_be_bytes() } else { x.to_le_bytes() };
                self.buf.extend_from_slice(&b);
                self
            }
        )*
    };
}

/// Builds a binary PLY. `be` chooses big endian.
struct Bin {
    buf: Vec<u8>,
    be: bool,
}

impl Bin {
    fn new(header: &str, be: bool) -> Self {
        Bin {
            buf: header.as_bytes().to_vec(),
            be,
        }
    }
    bin_writers!(f32, f64, i32, u32, u16);
    fn u8(&mut self, x: u8) -> &mut Self {
        self.buf.push(x);
        self
    }
}

fn binary_ply(be: bool, count_int: bool) -> Vec<u8> {
    let t = tetra();
    let enc = if be { "big" } else { "little" };
    let count = if count_int { "int" } else { "uchar" };
    let header = format!(
        "ply\nformat binary_{enc}_endian 1.0\ncomment hand made\n\
         element material 1\nproperty uchar red\nproperty float shine\n\
         element vertex 4\nproperty double x\nproperty float confidence\nproperty double y\n\
         property double z\nproperty uchar red\n\
         element face 4\nproperty uchar flags\nproperty list {count} int vertex_indices\n\
         property list uchar float texcoord\n\
         element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
    );
    let mut b = Bin::new(&header, be);
    b.u8(7).f32(0.5);
    for (k, p) in t.vertices.iter().enumerate() {
        b.f64(p.x).f32(0.25).f64(p.y).f64(p.z).u8(k as u8);
    }
    for f in &t.faces {
        b.u8(1);
        if count_int {
            b.i32(3);
        } else {
            b.u8(3);
        }
        for &i in f {
            b.i32(i as i32);
        }
        b.u8(2).f32(0.1).f32(0.2);
    }
    b.i32(0).i32(1);
    b.buf
}

#[test]
fn binary_ply_both_endiannesses_and_count_types() {
    let d = tmp();
    for be in [true, false] {
        for count_int in [true, false] {
            let p = write(d.path(), "b.ply", binary_ply(be, count_int));
            assert_eq!(read_raw(&p).unwrap(), tetra(), "be={be} int={count_int}");
        }
    }
}

#[test]
fn binary_ply_float_coords_uint_indices_ushort_count_quads() {
    let d = tmp();
    let header = "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty float x\n\
                  property float y\nproperty float z\nelement face 1\n\
                  property list ushort uint vertex_index\nend_header\n";
    let mut b = Bin::new(header, true);
    for (x, y) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
        b.f32(x).f32(y).f32(0.5);
    }
    b.u16(4).u32(0).u32(1).u32(2).u32(3);
    let p = write(d.path(), "q.ply", &b.buf);
    let r = read_raw(&p).unwrap();
    assert_eq!(r.vertices[2], Point::new(1.0, 1.0, 0.5));
    assert_eq!(r.faces, vec![[0, 1, 2], [0, 2, 3]]);
}

#[test]
fn ascii_ply_with_extra_properties() {
    let d = tmp();
    let s = "ply\nformat ascii 1.0\ncomment x\nelement vertex 4\nproperty float x\n\
             property float y\nproperty float z\nproperty uchar red\nproperty float nx\n\
             element face 4\nproperty list uchar int vertex_index\nproperty int tag\nend_header\n\
             0 0 0 1 0.5\n1 0 0 2 0.5\n0 1 0 3 0.5\n0 0 1.5 4 0.5\n\
             3 0 2 1 9\n3 0 1 3 9\n3 1 2 3 9\n3 0 3 2 9\n";
    let p = write(d.path(), "a.ply", s);
    assert_eq!(read_raw(&p).unwrap(), tetra());
}

// --------------------------------------------------------- malformed input

#[test]
fn truncated_binary_ply_is_an_error() {
    let d = tmp();
    let full = binary_ply(true, false);
    let header = full.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    for cut in [full.len() - 3, full.len() - 40, header + 10, header] {
        let p = write(d.path(), "trunc.ply", &full[..cut]);
        let e = read_raw(&p).expect_err("truncated").to_string();
        assert!(e.contains("trunc.ply") && e.contains("element"), "{e}");
    }
    // Cut inside the header.
    let p = write(d.path(), "trunc.ply", &full[..header / 2]);
    assert_err(read_raw(&p), &p, &["header"]);
}

#[test]
fn garbled_ply_header_is_an_error() {
    let d = tmp();
    let cases: [(&str, &[u8]); 5] = [
        ("g1.ply", b"ply\nformat ascii 1.0\nelement vertex three\nend_header\n"),
        ("g2.ply", b"plx\nformat ascii 1.0\nend_header\n"),
        ("g3.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n"),
        ("g4.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar float vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
        ("g5.ply", b"ply\nformat ascii 1.0\nelement vertex 1\n"),
    ];
    for (name, bytes) in cases {
        let p = write(d.path(), name, bytes);
        let e = read_raw(&p).expect_err(name).to_string();
        assert!(e.contains(name) && e.contains("header"), "{e}");
    }
}

#[test]
fn ply_huge_announced_count_fails_fast() {
    let d = tmp();
    for enc in ["ascii", "binary_little_endian"] {
        let mut bytes = format!(
            "ply\nformat {enc} 1.0\nelement vertex 4000000000\nproperty float x\n\
             property float y\nproperty float z\nelement face 4000000000\n\
             property list uchar int vertex_indices\nend_header\n"
        )
        .into_bytes();
        bytes.extend_from_slice(if enc == "ascii" {
            b"0 0 0\n"
        } else {
            &[0u8; 12]
        });
        let p = write(d.path(), "huge.ply", bytes);
        let t = std::time::Instant::now();
        assert_err(read_raw(&p), &p, &["vertex"]);
        assert!(t.elapsed().as_secs_f64() < 1.0);
    }
    // Same for a face list announcing 4e9 corners.
    let mut b = Bin::new(
        "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n\
         property float y\nproperty float z\nelement face 1\n\
         property list uint int vertex_indices\nend_header\n",
        false,
    );
    b.f32(0.0).f32(0.0).f32(0.0).u32(4_000_000_000).i32(0);
    let p = write(d.path(), "hugelist.ply", &b.buf);
    assert_err(read_raw(&p), &p, &["face"]);
}

#[test]
fn ascii_ply_counts_disagree_with_data() {
    let d = tmp();
    let s = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
             0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let p = write(d.path(), "short.ply", s);
    assert_err(read_raw(&p), &p, &["element 'vertex'", "expected 5, got 4"]);
    let s = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
             0 0 0\n1 0 0\n0 1 0\n3 0 1\n";
    let p = write(d.path(), "shortface.ply", s);
    assert_err(read_raw(&p), &p, &["element 'face'"]);
    let s = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
             0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n";
    let p = write(d.path(), "word.ply", s);
    assert_err(read_raw(&p), &p, &["element 'vertex'"]);
    let s = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
             0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n";
    let p = write(d.path(), "neg.ply", s);
    assert_err(read_raw(&p), &p, &["face 0", "negative index -1"]);
}

#[test]
fn face_index_out_of_range() {
    let d = tmp();
    let files = [
        (
            "oor.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n".to_string(),
        ),
        (
            "oor.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n".to_string(),
        ),
        (
            "oor.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
             0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"
                .to_string(),
        ),
    ];
    for (name, s) in files {
        let p = write(d.path(), name, s);
        // The raw reader keeps the index so the defect report can name it ...
        assert_eq!(read_raw(&p).unwrap().faces, vec![[0, 1, 3]]);
        // ... and the validating reader refuses it.
        assert_err(read_mesh(&p), &p, &["face 0", "vertex 3", "3 vertices"]);
    }
    let p = write(d.path(), "zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
    assert_err(read_raw(&p), &p, &["line 4", "index 0"]);
    let p = write(
        d.path(),
        "rel.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
    );
    assert_err(read_raw(&p), &p, &["line 4", "-4"]);
}

#[test]
fn nan_coordinate() {
    let d = tmp();
    let files = [
        ("nan.off", "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"),
        ("nan.obj", "v 0 0 0\nv 1 NaN 0\nv 0 1 0\nf 1 2 3\n"),
        ("nan.vert", "0 0 0\n1 nan 0\n0 1 0\n"),
    ];
    write(d.path(), "nan.tri", "1 2 3\n");
    for (name, s) in files {
        let p = write(d.path(), name, s);
        assert!(read_raw(&p).unwrap().vertices[1].y.is_nan());
        assert_err(read_mesh(&p), &p, &["vertex 1", "non-finite"]);
    }
    let p = write(
        d.path(),
        "word.off",
        "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n",
    );
    assert_err(read_raw(&p), &p, &["line 4", "'x' is not a number"]);
}

#[test]
fn off_counts_disagree_with_data() {
    let d = tmp();
    let p = write(d.path(), "fewv.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n");
    assert_err(read_raw(&p), &p, &["3 of the 4 vertices"]);
    let p = write(
        d.path(),
        "fewf.off",
        "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    );
    assert_err(read_raw(&p), &p, &["1 of the 2 faces"]);
    let p = write(
        d.path(),
        "more.off",
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n",
    );
    assert_err(read_raw(&p), &p, &["line 7", "unexpected data"]);
    let p = write(
        d.path(),
        "poly.off",
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n",
    );
    assert_err(
        read_raw(&p),
        &p,
        &["line 6", "announces 4 corners but lists 3"],
    );
    let p = write(d.path(), "kw.off", "4OFF\n3 1 0\n0 0 0 0\n");
    assert_err(read_raw(&p), &p, &["line 1", "'4OFF'"]);
}

#[test]
fn empty_files_are_errors() {
    let d = tmp();
    for name in ["e.ply", "e.off"] {
        let p = write(d.path(), name, "");
        assert_err(read_raw(&p), &p, &[]);
    }
    // An empty OBJ or .vert/.tri pair reads as an empty raw mesh, which the
    // validating reader rejects.
    for name in ["e.obj", "e.vert"] {
        let p = write(d.path(), name, "");
        write(d.path(), "e.tri", "");
        assert!(read_raw(&p).unwrap().faces.is_empty());
        assert_err(read_mesh(&p), &p, &["no faces"]);
    }
}

#[test]
fn missing_files() {
    let d = tmp();
    let p = write(d.path(), "lonely.vert", "0 0 0\n1 0 0\n0 1 0\n");
    assert_err(read_raw(&p), &p, &["lonely.tri", "missing"]);
    let p = write(d.path(), "alone.tri", "1 2 3\n");
    assert_err(read_raw(&p), &p, &["alone.vert", "missing"]);
    let p = d.path().join("nothing.ply");
    assert_err(read_raw(&p), &p, &[]);
    let p = write(d.path(), "mesh.stl", "solid");
    assert_err(read_raw(&p), &p, &["unknown mesh format"]);
    let p = write(d.path(), "bad.tri", "1 2 3\n0 1 2\n");
    write(d.path(), "bad.vert", "0 0 0\n1 0 0\n0 1 0\n");
    assert_err(read_raw(&p), &p, &["line 2", "one-based"]);
    let p = write(d.path(), "two.tri", "1 2\n");
    write(d.path(), "two.vert", "0 0 0\n1 0 0\n0 1 0\n");
    assert_err(read_raw(&p), &p, &["line 1", "expected 3 vertex indices"]);
}

#[test]
fn random_bytes_never_panic() {
    // A cheap fuzz: deterministic pseudo-random corruptions of valid files.
    let d = tmp();
    let mut seeds: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = || {
        seeds ^= seeds << 13;
        seeds ^= seeds >> 7;
        seeds ^= seeds << 17;
        seeds
    };
    let sources: Vec<(&str, Vec<u8>)> = vec![
        ("f.ply", binary_ply(true, true)),
        (
            "f.off",
            b"OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n4 0 1 3 2\n".to_vec(),
        ),
        (
            "f.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 -1/3\n".to_vec(),
        ),
    ];
    for (name, src) in &sources {
        for _ in 0..200 {
            let mut b = src.clone();
            for _ in 0..1 + next() % 4 {
                let i = (next() as usize) % b.len();
                b[i] = next() as u8;
            }
            if next() % 3 == 0 {
                b.truncate((next() as usize) % b.len());
            }
            let p = write(d.path(), name, &b);
            let _ = read_mesh(&p);
        }
    }
}

// ---------------------------------------------------------------- real data

fn files_in(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

#[test]
fn real_data_loads() {
    type Case<'a> = (&'a str, &'a str, Option<(usize, usize)>);
    let cases: [Case; 6] = [
        ("faust", "ply", Some((6890, 13776))),
        ("cactus", "ply", Some((5261, 10518))),
        ("tosca", "off", None),
        ("sumner/cat-lion", "obj", None),
        ("sumner/horse-camel", "obj", None),
        ("armadillo", "obj", Some((25002, 50000))),
    ];
    for (sub, ext, counts) in cases {
        let Some(dir) = shared_data_or_skip(sub, "real_data_loads") else {
            continue;
        };
        let files = files_in(&dir, ext);
        assert!(!files.is_empty(), "no .{ext} in {}", dir.display());
        for f in files {
            let m = read_mesh(&f).unwrap_or_else(|e| panic!("{e}"));
            if let Some(c) = counts {
                assert_eq!((m.n_vertices(), m.n_faces()), c, "{}", f.display());
            }
            let name = f.file_stem().unwrap().to_str().unwrap();
            let want_v = match name {
                n if n.starts_with("cat-") => 7207,
                n if n.starts_with("lion-") => 5000,
                n if n.starts_with("horse") && sub.starts_with("sumner") => 8431,
                "camel_ref" => 21887,
                n if n.starts_with("centaur") => 15768,
                n if n.starts_with("wolf") => 4344,
                n if n.starts_with("horse") => 19248,
                n if n.starts_with("cat") => 27894,
                _ => m.n_vertices(),
            };
            assert_eq!(m.n_vertices(), want_v, "{}", f.display());
        }
    }
}

//! `deformlab._native`: the thin pyo3 layer over the deformlab library.
//!
//! Every function converts numpy arrays to the library's types, checks them
//! (shapes, finite coordinates, index ranges: a `ValueError` naming the
//! argument), releases the GIL around the library call and converts the
//! result back. Options left `None` take the library's `Default` (the one
//! default of the CLI and the configs); string options are parsed with the
//! CLI's own value names (`clap::ValueEnum`), so `mode="per-handle"` means
//! what `--weights per-handle` means. The public Python API (docstrings,
//! argument coercion, scipy/pandas conversion) is `python/deformlab/`.

use std::path::PathBuf;
use std::sync::Arc;

use clap::ValueEnum;
use nalgebra::DMatrix;
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, PyReadonlyArray2};
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use deformlab::data::synthetic::FaustStyle;
use deformlab::experiment::{run_configs, LoadOptions, RunOptions};
use deformlab::mesh::validate::{DefectReport, Offenders};
use deformlab::mesh::{Face, RawMesh};
use deformlab::methods::completion::{
    CompletionProblem, CompletionSolver, FbtOptions, FeatureOptions, PipelineKind, SolverKind,
};
use deformlab::methods::external::{register_callable, unregister_callable, CallInput, CallableFn};
use deformlab::methods::spec::{BbwTolerance, Epsilon, MaxKeypoints, NCandidates};
use deformlab::methods::{
    transfer_method, FbtRegistrar, KeypointSource, MethodKind, TargetCorrespondence, TargetPoints,
    TransferCase, TransferMethod,
};
use deformlab::ops::heat::{HeatGeodesics, HeatOptions};
use deformlab::ops::{cotan_laplacian, farthest_point_sampling, mass_matrix, FpsMetric, MassKind};
use deformlab::skin::bbw::{bounded_biharmonic_weights, BbwOptions, WeightMode};
use deformlab::solve::{generalized_eigen, EigenOptions};
use deformlab::transfer::keypoints::{ErrorNorm, KeypointOptions, SelectionMode};
use deformlab::transfer::{auto_correspondence, AutoOptions};
use deformlab::{Error, Mesh, Point};

// ---------------------------------------------------------------------------
// Errors and conversions

/// The library's errors as Python exceptions: bad input (also a malformed
/// file) is a `ValueError`, a file the system refused an `OSError`, a
/// numerical failure a `RuntimeError`.
fn py_err(e: Error) -> PyErr {
    match e {
        Error::Io { .. } => PyOSError::new_err(e.to_string()),
        Error::Parse { .. } | Error::InvalidInput(_) => PyValueError::new_err(e.to_string()),
        Error::Numerical(_) => PyRuntimeError::new_err(e.to_string()),
    }
}

fn value_err(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// Vertices from an `n × 3` float64 array (`name` for the messages).
fn points(name: &str, v: &PyReadonlyArray2<'_, f64>, finite: bool) -> PyResult<Vec<Point>> {
    let a = v.as_array();
    if a.ncols() != 3 {
        return Err(value_err(format!(
            "{name}: expected an n×3 array of vertex positions, got shape {:?}",
            a.shape()
        )));
    }
    let mut out = Vec::with_capacity(a.nrows());
    for (i, r) in a.rows().into_iter().enumerate() {
        if finite && !(r[0].is_finite() && r[1].is_finite() && r[2].is_finite()) {
            return Err(value_err(format!(
                "{name}: vertex {i} has a non-finite coordinate ({}, {}, {})",
                r[0], r[1], r[2]
            )));
        }
        out.push(Point::new(r[0], r[1], r[2]));
    }
    Ok(out)
}

/// Faces from an `m × 3` int64 array; indices must be `0 ≤ i < n` (when
/// `n` is given) and never negative.
fn faces(name: &str, f: &PyReadonlyArray2<'_, i64>, n: Option<usize>) -> PyResult<Vec<Face>> {
    let a = f.as_array();
    if a.ncols() != 3 {
        return Err(value_err(format!(
            "{name}: expected an m×3 array of triangle vertex indices, got shape {:?}",
            a.shape()
        )));
    }
    let mut out = Vec::with_capacity(a.nrows());
    for (fi, r) in a.rows().into_iter().enumerate() {
        let mut face = [0usize; 3];
        for k in 0..3 {
            let x = r[k];
            let ok = x >= 0 && n.is_none_or(|n| (x as u64) < n as u64);
            if !ok {
                return Err(value_err(format!(
                    "{name}: face {fi} uses vertex {x}, out of range{}",
                    n.map(|n| format!(" (the mesh has {n} vertices: 0..{n})"))
                        .unwrap_or_default()
                )));
            }
            face[k] = x as usize;
        }
        out.push(face);
    }
    Ok(out)
}

/// A checked mesh from `(V, F)`.
fn mesh(
    name: &str,
    v: &PyReadonlyArray2<'_, f64>,
    f: &PyReadonlyArray2<'_, i64>,
) -> PyResult<Mesh> {
    let pts = points(&format!("{name} vertices"), v, true)?;
    let fs = faces(&format!("{name} faces"), f, Some(pts.len()))?;
    if fs.is_empty() {
        return Err(value_err(format!("{name} faces: the mesh has no faces")));
    }
    Mesh::new(pts, fs).map_err(|e| value_err(format!("{name}: {e}")))
}

/// Vertex indices (`name`), each `< n`.
fn indices(name: &str, idx: &[i64], n: usize) -> PyResult<Vec<usize>> {
    idx.iter()
        .enumerate()
        .map(|(k, &x)| {
            if x < 0 || x as u64 >= n as u64 {
                Err(value_err(format!(
                    "{name}: entry {k} is vertex {x}, out of range (0..{n})"
                )))
            } else {
                Ok(x as usize)
            }
        })
        .collect()
}

fn points_array<'py>(py: Python<'py>, p: &[Point]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = p.iter().flat_map(|q| [q.x, q.y, q.z]).collect();
    let arr = Array2::from_shape_vec((p.len(), 3), flat).expect("n×3 shape of n points");
    PyArray2::from_owned_array(py, arr)
}

fn faces_array<'py>(py: Python<'py>, f: &[Face]) -> Bound<'py, PyArray2<i64>> {
    let flat: Vec<i64> = f.iter().flat_map(|t| t.map(|i| i as i64)).collect();
    let arr = Array2::from_shape_vec((f.len(), 3), flat).expect("m×3 shape of m faces");
    PyArray2::from_owned_array(py, arr)
}

fn dmatrix_array<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    let arr = Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]);
    PyArray2::from_owned_array(py, arr)
}

/// A CLI value name (`per-handle`, `unit-sphere`; `_` accepted for `-`).
fn parse_enum<T: ValueEnum>(name: &str, s: &str) -> PyResult<T> {
    T::from_str(&s.replace('_', "-"), true).map_err(|_| {
        let names: Vec<String> = T::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value().map(|p| p.get_name().to_string()))
            .collect();
        value_err(format!(
            "{name}: unknown value {s:?}; expected one of {}",
            names.join(", ")
        ))
    })
}

// ---------------------------------------------------------------------------
// Mesh I/O and inspection

/// `(V, F)` as numpy arrays.
type MeshArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>);
/// `(λ, Φ)` as numpy arrays.
type Eigen<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray2<f64>>);

/// Reads a mesh file (PLY, OFF, OBJ, TOSCA .vert/.tri): `(V, F)`.
#[pyfunction]
fn read_mesh<'py>(py: Python<'py>, path: PathBuf) -> PyResult<MeshArrays<'py>> {
    let m = py
        .detach(|| deformlab::mesh::io::read_mesh(&path))
        .map_err(py_err)?;
    Ok((points_array(py, m.vertices()), faces_array(py, m.faces())))
}

/// Writes a mesh; the format follows the extension (.ply binary, .obj, .off).
#[pyfunction]
fn write_mesh(
    py: Python<'_>,
    path: PathBuf,
    v: PyReadonlyArray2<'_, f64>,
    f: PyReadonlyArray2<'_, i64>,
) -> PyResult<()> {
    let m = mesh("mesh", &v, &f)?;
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    py.detach(|| match ext.as_str() {
        "ply" => deformlab::mesh::io::write_ply(&path, &m),
        "obj" => deformlab::mesh::io::write_obj(&path, &m),
        "off" => deformlab::mesh::io::write_off(&path, &m),
        _ => Err(Error::invalid(format!(
            "path {}: unknown mesh extension {ext:?}; expected .ply, .obj or .off",
            path.display()
        ))),
    })
    .map_err(py_err)
}

fn offenders_list<'py, T: Clone + IntoPyObject<'py>>(
    py: Python<'py>,
    o: &Offenders<T>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("count", o.count)?;
    d.set_item("first", PyList::new(py, o.first.iter().cloned())?)?;
    Ok(d)
}

/// The defect report of raw arrays (out-of-range faces and non-finite
/// coordinates are reported, not refused).
#[pyfunction]
fn inspect<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: PyReadonlyArray2<'_, i64>,
) -> PyResult<Bound<'py, PyDict>> {
    let raw = RawMesh {
        vertices: points("V", &v, false)?,
        faces: faces("F", &f, None)?,
    };
    let r = py.detach(|| DefectReport::of(&raw));
    let d = PyDict::new(py);
    d.set_item("n_vertices", r.n_vertices)?;
    d.set_item("n_faces", r.n_faces)?;
    d.set_item("n_edges", r.n_edges)?;
    d.set_item("euler_characteristic", r.euler_characteristic)?;
    d.set_item("clean", r.is_clean())?;
    d.set_item("clean_ignoring_boundary", r.is_clean_ignoring_boundary())?;
    d.set_item("loadable", r.is_loadable())?;
    d.set_item("genus", r.genus())?;
    d.set_item("summary", r.summary())?;
    for (k, o) in [
        ("out_of_range_faces", &r.out_of_range_faces),
        ("non_finite_vertices", &r.non_finite_vertices),
        ("repeated_index_faces", &r.repeated_index_faces),
        ("zero_area_faces", &r.zero_area_faces),
        ("duplicate_faces", &r.duplicate_faces),
        ("unreferenced_vertices", &r.unreferenced_vertices),
        ("non_manifold_vertices", &r.non_manifold_vertices),
    ] {
        d.set_item(k, offenders_list(py, o)?)?;
    }
    for (k, o) in [
        ("boundary_edges", &r.boundary_edges),
        ("non_manifold_edges", &r.non_manifold_edges),
        ("inconsistent_edges", &r.inconsistent_edges),
    ] {
        d.set_item(k, offenders_list(py, o)?)?;
    }
    let comps = PyList::empty(py);
    for c in &r.components {
        let cd = PyDict::new(py);
        cd.set_item("first_face", c.first_face)?;
        cd.set_item("n_faces", c.n_faces)?;
        cd.set_item("n_vertices", c.n_vertices)?;
        cd.set_item("n_edges", c.n_edges)?;
        cd.set_item("euler_characteristic", c.euler_characteristic)?;
        cd.set_item("boundary_edges", c.boundary_edges)?;
        cd.set_item("boundary_loops", c.boundary_loops)?;
        cd.set_item("manifold", c.manifold)?;
        cd.set_item("orientable", c.orientable)?;
        cd.set_item("faces_to_flip", c.faces_to_flip)?;
        cd.set_item("genus", c.genus)?;
        comps.append(cd)?;
    }
    d.set_item("components", comps)?;
    Ok(d)
}

// ---------------------------------------------------------------------------
// Operators

type Csr<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    (usize, usize),
);

/// The positive semi-definite cotangent Laplacian as CSR parts
/// `(data, indices, indptr, shape)`.
#[pyfunction]
fn cotmatrix<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: PyReadonlyArray2<'_, i64>,
) -> PyResult<Csr<'py>> {
    let m = mesh("mesh", &v, &f)?;
    let l = py.detach(|| cotan_laplacian(&m));
    // L is exactly symmetric (each edge's value is stored on both sides), so
    // its compressed columns are its compressed rows: no conversion.
    let (offsets, cols, vals) = l.csc_data();
    Ok((
        PyArray1::from_slice(py, vals),
        PyArray1::from_iter(py, cols.iter().map(|&c| c as i64)),
        PyArray1::from_iter(py, offsets.iter().map(|&c| c as i64)),
        (l.nrows(), l.ncols()),
    ))
}

/// The lumped mass matrix's diagonal (`kind`: "voronoi" or "barycentric";
/// `None`: the library's default).
#[pyfunction]
#[pyo3(signature = (v, f, kind=None))]
fn massmatrix<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: PyReadonlyArray2<'_, i64>,
    kind: Option<&str>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let m = mesh("mesh", &v, &f)?;
    let kind = match kind.map(|s| s.to_ascii_lowercase()) {
        None => MassKind::default(),
        Some(s) if s == "voronoi" => MassKind::Voronoi,
        Some(s) if s == "barycentric" => MassKind::Barycentric,
        Some(s) => {
            return Err(value_err(format!(
                "kind: unknown mass matrix {s:?}; expected \"voronoi\" or \"barycentric\""
            )))
        }
    };
    let d = py.detach(|| mass_matrix(&m, kind));
    Ok(PyArray1::from_vec(py, d))
}

/// The `k` smallest eigenpairs of `L φ = λ M φ` (cotangent L, Voronoi M):
/// `(λ (k,), Φ (n × k))`, Φ M-orthonormal, verified by the library.
#[pyfunction]
#[pyo3(signature = (v, f, k, seed=None))]
fn lbo_eigenpairs<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: PyReadonlyArray2<'_, i64>,
    k: i64,
    seed: Option<u64>,
) -> PyResult<Eigen<'py>> {
    let m = mesh("mesh", &v, &f)?;
    let n = m.n_vertices();
    if k < 1 || k as u64 > n as u64 {
        return Err(value_err(format!(
            "k: expected 1..={n} eigenpairs, got {k}"
        )));
    }
    let d = EigenOptions::default();
    let opts = EigenOptions {
        seed: seed.unwrap_or(d.seed),
        ..d
    };
    let e = py
        .detach(|| {
            let l = cotan_laplacian(&m);
            let mass = mass_matrix(&m, MassKind::Voronoi);
            generalized_eigen(&l, &mass, k as usize, &opts)
        })
        .map_err(py_err)?;
    Ok((
        PyArray1::from_slice(py, &e.values),
        dmatrix_array(py, &e.vectors),
    ))
}

/// Heat-method geodesic distances from `sources` (one value per vertex).
#[pyfunction]
#[pyo3(signature = (v, f, sources, time_factor=None))]
fn heat_geodesic<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: PyReadonlyArray2<'_, i64>,
    sources: Vec<i64>,
    time_factor: Option<f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let m = mesh("mesh", &v, &f)?;
    let src = indices("sources", &sources, m.n_vertices())?;
    if src.is_empty() {
        return Err(value_err("sources: expected at least one source vertex"));
    }
    let d = HeatOptions::default();
    let opts = HeatOptions {
        time_factor: time_factor.unwrap_or(d.time_factor),
        ..d
    };
    if !(opts.time_factor.is_finite() && opts.time_factor > 0.0) {
        return Err(value_err(format!(
            "time_factor: expected a positive finite number, got {}",
            opts.time_factor
        )));
    }
    let dist = py
        .detach(|| HeatGeodesics::new(&m, &opts)?.distance(&src))
        .map_err(py_err)?;
    Ok(PyArray1::from_vec(py, dist))
}

/// `k` farthest point samples (metric "euclidean" or "geodesic"; `None`:
/// the library's default), starting from a seeded vertex.
#[pyfunction]
#[pyo3(signature = (v, f, k, metric=None, seed=None))]
fn fps<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: PyReadonlyArray2<'_, i64>,
    k: i64,
    metric: Option<&str>,
    seed: Option<u64>,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let m = mesh("mesh", &v, &f)?;
    let n = m.n_vertices();
    if k < 0 || k as u64 > n as u64 {
        return Err(value_err(format!("k: expected 0..={n} samples, got {k}")));
    }
    let metric = match metric {
        Some(s) => parse_enum::<FpsMetric>("metric", s)?,
        None => FpsMetric::default(),
    };
    let seed = seed.unwrap_or_default();
    let s = py
        .detach(|| farthest_point_sampling(&m, k as usize, metric, seed))
        .map_err(py_err)?;
    Ok(PyArray1::from_iter(py, s.into_iter().map(|i| i as i64)))
}

/// Bounded biharmonic weights (n × handles) for point handles; `tol` is the
/// active-set tolerance of the chosen mode (`tol` of per-handle,
/// `coupled_tol` of coupled; `None`: the library's).
#[pyfunction]
#[pyo3(signature = (v, f, handles, mode=None, tol=None))]
fn bbw<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'_, f64>,
    f: PyReadonlyArray2<'_, i64>,
    handles: Vec<i64>,
    mode: Option<&str>,
    tol: Option<f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m = mesh("mesh", &v, &f)?;
    let h = indices("handles", &handles, m.n_vertices())?;
    if h.is_empty() {
        return Err(value_err("handles: expected at least one handle vertex"));
    }
    let mut seen = std::collections::BTreeSet::new();
    if let Some(d) = h.iter().find(|&&x| !seen.insert(x)) {
        return Err(value_err(format!("handles: vertex {d} is given twice")));
    }
    let mut opts = match mode {
        Some(s) => BbwOptions::with_mode(parse_enum::<WeightMode>("mode", s)?),
        None => BbwOptions::default(),
    };
    if let Some(t) = tol {
        opts.set_mode_tol(BbwTolerance::check(t).map_err(|e| value_err(format!("tol: {e}")))?);
    }
    let w = py
        .detach(|| bounded_biharmonic_weights(&m, &h, &opts))
        .map_err(py_err)?;
    Ok(dmatrix_array(py, &w))
}

// ---------------------------------------------------------------------------
// BDT

/// The selection options from keyword values (`None`: the library's
/// default), with the CLI's range checks.
#[allow(clippy::too_many_arguments)]
fn keypoint_options(
    n_candidates: Option<i64>,
    seed: Option<u64>,
    epsilon: Option<f64>,
    max_keypoints: Option<i64>,
    mode: Option<&str>,
    error_norm: Option<&str>,
    weights: Option<&str>,
    n_vertices: usize,
) -> PyResult<KeypointOptions> {
    let d = KeypointOptions::default();
    let n_candidates = match n_candidates {
        Some(x) => NCandidates::parse(&x.to_string())
            .map_err(|e| value_err(format!("n_candidates: {e}")))?,
        None => d.n_candidates,
    };
    if n_candidates > n_vertices {
        return Err(value_err(format!(
            "n_candidates: {n_candidates} exceeds the {n_vertices} vertices of the source"
        )));
    }
    Ok(KeypointOptions {
        n_candidates,
        seed: seed.unwrap_or(d.seed),
        epsilon: match epsilon {
            Some(x) => {
                Epsilon::parse(&x.to_string()).map_err(|e| value_err(format!("epsilon: {e}")))?
            }
            None => d.epsilon,
        },
        max_keypoints: match max_keypoints {
            Some(x) => MaxKeypoints::parse(&x.to_string())
                .map_err(|e| value_err(format!("max_keypoints: {e}")))?,
            None => d.max_keypoints,
        },
        mode: match mode {
            Some(s) => parse_enum::<SelectionMode>("mode", s)?,
            None => d.mode,
        },
        error_norm: match error_norm {
            Some(s) => parse_enum::<ErrorNorm>("error_norm", s)?,
            None => d.error_norm,
        },
        weights: match weights {
            Some(s) => BbwOptions::with_mode(parse_enum::<WeightMode>("weights", s)?),
            None => d.weights,
        },
        ..d
    })
}

/// Source mesh and its deformed poses (each `n × 3`, A's faces).
fn source_and_poses(
    av: &PyReadonlyArray2<'_, f64>,
    af: &PyReadonlyArray2<'_, i64>,
    poses: &[PyReadonlyArray2<'_, f64>],
) -> PyResult<(Mesh, Vec<Mesh>)> {
    let a = mesh("A", av, af)?;
    if a.component_count() > 1 {
        return Err(value_err(format!(
            "A: {} connected components; the source must be one connected surface",
            a.component_count()
        )));
    }
    if poses.is_empty() {
        return Err(value_err("A_primes: expected at least one deformed pose"));
    }
    let mut out = Vec::with_capacity(poses.len());
    for (j, p) in poses.iter().enumerate() {
        let pts = points(&format!("A_primes[{j}]"), p, true)?;
        if pts.len() != a.n_vertices() {
            return Err(value_err(format!(
                "A_primes[{j}]: {} vertices, but A has {}",
                pts.len(),
                a.n_vertices()
            )));
        }
        out.push(a.with_vertices(pts).map_err(py_err)?);
    }
    Ok((a, out))
}

fn transforms_array<'py>(
    py: Python<'py>,
    t: &[Vec<deformlab::skin::Affine>],
) -> Bound<'py, PyArray2<f64>> {
    // Flattened (m·k) × 12, reshaped to m × k × 3 × 4 on the Python side.
    let rows = t.iter().map(|x| x.len()).sum::<usize>();
    let mut flat = Vec::with_capacity(rows * 12);
    for pose in t {
        for a in pose {
            for i in 0..3 {
                for j in 0..4 {
                    flat.push(a[(i, j)]);
                }
            }
        }
    }
    let arr = Array2::from_shape_vec((rows, 12), flat).expect("12 entries per transform");
    PyArray2::from_owned_array(py, arr)
}

/// BDT Algorithm 1 through `KeypointSource::Automatic` (the entry point of
/// the CLI and the harness).
#[pyfunction]
#[pyo3(signature = (av, af, poses, n_candidates=None, seed=None, epsilon=None,
    max_keypoints=None, mode=None, error_norm=None, weights=None))]
#[allow(clippy::too_many_arguments)]
fn select_keypoints<'py>(
    py: Python<'py>,
    av: PyReadonlyArray2<'_, f64>,
    af: PyReadonlyArray2<'_, i64>,
    poses: Vec<PyReadonlyArray2<'_, f64>>,
    n_candidates: Option<i64>,
    seed: Option<u64>,
    epsilon: Option<f64>,
    max_keypoints: Option<i64>,
    mode: Option<&str>,
    error_norm: Option<&str>,
    weights: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let (a, a_def) = source_and_poses(&av, &af, &poses)?;
    let opts = keypoint_options(
        n_candidates,
        seed,
        epsilon,
        max_keypoints,
        mode,
        error_norm,
        weights,
        a.n_vertices(),
    )?;
    let picked = py
        .detach(|| {
            KeypointSource::Automatic {
                selection_poses: None,
            }
            .pick(&a, &a_def, &opts)
        })
        .map_err(py_err)?;
    let (sel, _) = picked
        .selection
        .ok_or_else(|| PyRuntimeError::new_err("the automatic selection returned no trace"))?;
    let d = PyDict::new(py);
    d.set_item("keypoints", &sel.keypoints)?;
    d.set_item("candidates", &sel.candidates)?;
    d.set_item("transforms", transforms_array(py, &sel.transforms))?;
    d.set_item("error", sel.error)?;
    let trace = PyList::empty(py);
    for s in &sel.trace {
        trace.append((s.stage, s.keypoints.clone(), s.error))?;
    }
    d.set_item("trace", trace)?;
    d.set_item("seconds", sel.seconds)?;
    d.set_item("evaluations", sel.evaluations)?;
    Ok(d)
}

/// The method entry of a keyword-option call, resolved through the
/// registry exactly like a config's `[[methods]]` entry: `options` is a
/// JSON object of entry keys (Python `None`s dropped by the caller).
fn method_from_options(kind: &str, options: Option<&str>) -> PyResult<TransferMethod> {
    let mut table = toml::Table::new();
    if let Some(text) = options {
        let json: serde_json::Value = serde_json::from_str(text)
            .map_err(|e| value_err(format!("options: not a JSON object ({e})")))?;
        let serde_json::Value::Object(map) = json else {
            return Err(value_err(
                "options: expected a mapping of option names to values",
            ));
        };
        for (k, v) in map {
            if v.is_null() {
                continue;
            }
            let v = toml::Value::try_from(&v).map_err(|e| value_err(format!("{k}: {e}")))?;
            table.insert(k, v);
        }
    }
    transfer_method(kind, &table).map_err(|(k, msg)| {
        value_err(if k.is_empty() {
            format!("method: {msg} (see deformlab.method_kinds())")
        } else {
            format!("{k}: {msg} (method {kind:?})")
        })
    })
}

/// The registry of method kinds: `(name, family, keys)` per kind.
#[pyfunction]
fn method_kinds() -> Vec<(&'static str, &'static str, Vec<&'static str>)> {
    MethodKind::ALL
        .iter()
        .map(|k| {
            let i = k.info();
            (i.name, i.family.name(), i.key_list())
        })
        .collect()
}

/// Deformation transfer through `TransferMethod::run` (the entry point of
/// `deformlab transfer` and of the harness), the method resolved through
/// the registry from its kind and keyword options.
#[pyfunction]
#[pyo3(signature = (av, af, poses, bv, bf, target_keypoints=None, keypoints=None,
    correspondence=None, landmarks=None, method=None, options=None))]
#[allow(clippy::too_many_arguments)]
fn transfer<'py>(
    py: Python<'py>,
    av: PyReadonlyArray2<'_, f64>,
    af: PyReadonlyArray2<'_, i64>,
    poses: Vec<PyReadonlyArray2<'_, f64>>,
    bv: PyReadonlyArray2<'_, f64>,
    bf: PyReadonlyArray2<'_, i64>,
    target_keypoints: Option<Vec<i64>>,
    keypoints: Option<Vec<i64>>,
    correspondence: Option<&str>,
    landmarks: Option<Vec<(i64, i64)>>,
    method: Option<&str>,
    options: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let kind = method.unwrap_or(MethodKind::Bdt.name());
    let mut m = method_from_options(kind, options)?;
    let (a, a_def) = source_and_poses(&av, &af, &poses)?;
    let b = mesh("B", &bv, &bf)?;
    let Some((source_kp, target_points, opts)) = m.keypoint_inputs_mut() else {
        for (name, set) in [
            ("keypoints", keypoints.is_some()),
            ("target_keypoints", target_keypoints.is_some()),
            ("correspondence", correspondence.is_some()),
            ("landmarks", landmarks.is_some()),
        ] {
            if set {
                return Err(value_err(format!(
                    "{name}: does not apply to method {kind:?} (it takes no key points)"
                )));
            }
        }
        return transfer_result(py, &m, &a, &a_def, &b);
    };
    if opts.n_candidates > a.n_vertices() {
        return Err(value_err(format!(
            "n_candidates: {} exceeds the {} vertices of the source",
            opts.n_candidates,
            a.n_vertices()
        )));
    }
    if let Some(k) = &keypoints {
        if k.is_empty() {
            return Err(value_err("keypoints: expected at least one key point"));
        }
        if !matches!(source_kp, KeypointSource::Automatic { .. }) {
            return Err(value_err(format!(
                "keypoints: method {kind:?} picks its own key points; drop one of them"
            )));
        }
        *source_kp = KeypointSource::Given(indices("keypoints", k, a.n_vertices())?);
    }
    let corr = match (correspondence, &target_keypoints) {
        (Some(_), Some(_)) => {
            return Err(value_err(
                "target_keypoints and correspondence: give one of them (a list of target \
                 vertices, or \"identity\" / \"auto\")",
            ))
        }
        (None, Some(t)) => {
            if keypoints.is_none() {
                return Err(value_err(
                    "target_keypoints: needs keypoints (the source key points they match, in \
                     order), as the CLI's --target-keypoints needs --keypoints",
                ));
            }
            TargetCorrespondence::List(indices("target_keypoints", t, b.n_vertices())?)
        }
        (Some("identity"), None) | (Some("same"), None) => TargetCorrespondence::Identity,
        (Some("auto"), None) => TargetCorrespondence::Auto,
        (Some(other), None) => {
            return Err(value_err(format!(
                "correspondence: unknown value {other:?}; expected \"identity\" or \"auto\""
            )))
        }
        (None, None) => TargetCorrespondence::default(),
    };
    let lm = match landmarks {
        Some(pairs) => {
            if corr != TargetCorrespondence::Auto {
                return Err(value_err(
                    "landmarks: they guide the automatic correspondence; add \
                     correspondence=\"auto\" or drop landmarks",
                ));
            }
            let s: Vec<i64> = pairs.iter().map(|p| p.0).collect();
            let t: Vec<i64> = pairs.iter().map(|p| p.1).collect();
            let s = indices("landmarks (source column)", &s, a.n_vertices())?;
            let t = indices("landmarks (target column)", &t, b.n_vertices())?;
            s.into_iter().zip(t).collect()
        }
        None => Vec::new(),
    };
    target_points.correspondence = corr;
    target_points.landmarks = lm;
    transfer_result(py, &m, &a, &a_def, &b)
}

/// Runs `m` and returns the binding's result dictionary.
fn transfer_result<'py>(
    py: Python<'py>,
    m: &TransferMethod,
    a: &Mesh,
    a_def: &[Mesh],
    b: &Mesh,
) -> PyResult<Bound<'py, PyDict>> {
    let out = py
        .detach(|| m.run(&TransferCase { a, a_def, b }))
        .map_err(py_err)?;
    let d = PyDict::new(py);
    let meshes = PyList::empty(py);
    for mm in &out.meshes {
        meshes.append(points_array(py, mm.vertices()))?;
    }
    d.set_item("meshes", meshes)?;
    d.set_item("method", m.kind_name())?;
    if let Some(p) = &out.keypoints {
        d.set_item("keypoints", &p.keypoints)?;
        if let Some((sel, _)) = &p.selection {
            let trace = PyList::empty(py);
            for s in &sel.trace {
                trace.append((s.stage, s.keypoints.clone(), s.error))?;
            }
            d.set_item("trace", trace)?;
        }
    }
    if let Some(t) = &out.target {
        d.set_item("target_keypoints", &t.keypoints)?;
        if let Some(r) = &t.auto {
            d.set_item("registered", points_array(py, r.registered.vertices()))?;
            d.set_item("registration_residual", r.residual)?;
        }
    }
    if let Some(fit) = &out.fit {
        d.set_item("fit_error", fit.error)?;
        d.set_item("transforms", transforms_array(py, &fit.transforms))?;
    }
    let t = &out.timings;
    let timings = PyDict::new(py);
    for (k, v) in [
        ("fit", t.fit),
        ("weights", t.weights),
        ("lbs", t.lbs),
        ("refine", t.refine),
        ("precompute", t.precompute),
        ("factorise", t.factorise),
        ("solve", t.solve),
    ] {
        if let Some(v) = v {
            timings.set_item(k, v)?;
        }
    }
    d.set_item("seconds", timings)?;
    Ok(d)
}

/// The automatic target correspondence: registers A onto B and returns the
/// target vertex of each key point.
#[pyfunction]
#[pyo3(signature = (av, af, keypoints, bv, bf, landmarks=None, seed=None))]
#[allow(clippy::too_many_arguments)]
fn target_correspondence<'py>(
    py: Python<'py>,
    av: PyReadonlyArray2<'_, f64>,
    af: PyReadonlyArray2<'_, i64>,
    keypoints: Vec<i64>,
    bv: PyReadonlyArray2<'_, f64>,
    bf: PyReadonlyArray2<'_, i64>,
    landmarks: Option<Vec<(i64, i64)>>,
    seed: Option<u64>,
) -> PyResult<Bound<'py, PyDict>> {
    let a = mesh("A", &av, &af)?;
    let b = mesh("B", &bv, &bf)?;
    let kp = indices("keypoints", &keypoints, a.n_vertices())?;
    if kp.is_empty() {
        return Err(value_err("keypoints: expected at least one key point"));
    }
    let lm: Vec<(usize, usize)> = match landmarks {
        Some(pairs) => {
            let s: Vec<i64> = pairs.iter().map(|p| p.0).collect();
            let t: Vec<i64> = pairs.iter().map(|p| p.1).collect();
            let s = indices("landmarks (source column)", &s, a.n_vertices())?;
            let t = indices("landmarks (target column)", &t, b.n_vertices())?;
            s.into_iter().zip(t).collect()
        }
        None => Vec::new(),
    };
    // The options of TargetPoints::find's automatic arm (the seed being
    // the method's, as there).
    let d = TargetPoints::default();
    let opts = AutoOptions {
        seed: seed.unwrap_or(d.seed),
        landmarks: lm,
        ..AutoOptions::default()
    };
    let r = py
        .detach(|| auto_correspondence(&a, &kp, &b, &opts))
        .map_err(py_err)?;
    let out = PyDict::new(py);
    out.set_item("target_keypoints", &r.target_keypoints)?;
    out.set_item("surface_points", points_array(py, &r.surface_points))?;
    out.set_item("registered", points_array(py, r.registered.vertices()))?;
    out.set_item("residual", r.residual)?;
    out.set_item("alpha", r.alpha)?;
    out.set_item("seconds", r.seconds)?;
    Ok(out)
}

// ---------------------------------------------------------------------------
// FBT

/// An FBT model: the examples (reference first), the shapes its skeleton
/// weights are learnt from, the options and seed; the precomputation of
/// `register` is built on first use and kept.
#[pyclass(module = "deformlab._native", name = "FbtModel")]
struct PyFbtModel {
    examples: Vec<Mesh>,
    rig: Vec<Mesh>,
    options: FbtOptions,
    seed: u64,
    setup: Option<FbtRegistrar>,
}

#[pymethods]
impl PyFbtModel {
    #[new]
    #[pyo3(signature = (vertices, f, rig=None, pipeline=None, m=None, clusters=None,
        bones=None, nicp=None, seed=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        vertices: Vec<PyReadonlyArray2<'_, f64>>,
        f: PyReadonlyArray2<'_, i64>,
        rig: Option<Vec<PyReadonlyArray2<'_, f64>>>,
        pipeline: Option<&str>,
        m: Option<i64>,
        clusters: Option<i64>,
        bones: Option<i64>,
        nicp: Option<bool>,
        seed: Option<u64>,
    ) -> PyResult<Self> {
        if vertices.is_empty() {
            return Err(value_err("examples: expected at least one example pose"));
        }
        let reference = mesh("examples[0]", &vertices[0], &f)?;
        let n = reference.n_vertices();
        let pose = |name: String, v: &PyReadonlyArray2<'_, f64>| -> PyResult<Mesh> {
            let p = points(&name, v, true)?;
            if p.len() != n {
                return Err(value_err(format!(
                    "{name}: {} vertices, but examples[0] has {n}",
                    p.len()
                )));
            }
            reference.with_vertices(p).map_err(py_err)
        };
        let mut examples = vec![reference.clone()];
        for (j, v) in vertices.iter().enumerate().skip(1) {
            examples.push(pose(format!("examples[{j}]"), v)?);
        }
        let rig = match rig {
            Some(r) => r
                .iter()
                .enumerate()
                .map(|(j, v)| pose(format!("rig[{j}]"), v))
                .collect::<PyResult<Vec<_>>>()?,
            None => examples[1..].to_vec(),
        };
        let d = FbtOptions::default();
        let positive = |name: &str, x: Option<i64>, def: usize| -> PyResult<usize> {
            match x {
                None => Ok(def),
                Some(x) if x >= 1 => Ok(x as usize),
                Some(x) => Err(value_err(format!("{name}: expected at least 1, got {x}"))),
            }
        };
        let options = FbtOptions {
            q: examples.len(),
            m: positive("m", m, d.m)?,
            clusters: positive("clusters", clusters, d.clusters)?,
            bones: match bones {
                None => d.bones,
                Some(b) => Some(positive("bones", Some(b), 1)?),
            },
            nicp: nicp.unwrap_or(d.nicp),
            pipeline: match pipeline {
                None => PipelineKind::default_for(rig.len()),
                Some(name) => PipelineKind::from_name(name).ok_or_else(|| {
                    value_err(format!(
                        "pipeline: unknown value {name:?}; expected one of {}",
                        PipelineKind::ALL
                            .iter()
                            .map(|p| format!("\"{}\"", p.name()))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ))
                })?,
            },
            ..d
        };
        if options.pipeline.uses_skeleton() && rig.is_empty() {
            return Err(value_err(format!(
                "rig: the {} pipeline learns its bones from other poses of the class; give more \
                 than one example, rig poses, or pipeline=\"lbo\"",
                options.pipeline.name()
            )));
        }
        Ok(PyFbtModel {
            examples,
            rig,
            options,
            seed: seed.unwrap_or_default(),
            setup: None,
        })
    }

    /// Number of examples q.
    #[getter]
    fn q(&self) -> usize {
        self.examples.len()
    }

    /// Number of template vertices.
    #[getter]
    fn n_vertices(&self) -> usize {
        self.examples[0].n_vertices()
    }

    /// The template's faces.
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        faces_array(py, self.examples[0].faces())
    }

    /// Registration to vertex-position constraints (`H = e_i`, `Y` given):
    /// the paper's schedule on the pipeline built from the examples.
    fn register<'py>(
        &mut self,
        py: Python<'py>,
        vertices: Vec<i64>,
        targets: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let idx = indices("vertices", &vertices, self.n_vertices())?;
        let y = points("targets", &targets, true)?;
        if idx.is_empty() || y.len() != idx.len() {
            return Err(value_err(format!(
                "constraints: {} vertices and {} target positions; expected as many, at least one",
                idx.len(),
                y.len()
            )));
        }
        if self.setup.is_none() {
            let (ex, rig, o, seed) = (&self.examples, &self.rig, &self.options, self.seed);
            let s = py
                .detach(|| FbtRegistrar::build(ex, rig, o, seed))
                .map_err(py_err)?;
            self.setup = Some(s);
        }
        let setup = self.setup.as_ref().expect("built above");
        let reg = py
            .detach(|| setup.register_vertices(&idx, &y))
            .map_err(py_err)?;
        let d = PyDict::new(py);
        d.set_item("V", points_array(py, &reg.positions))?;
        d.set_item("alpha", reg.alpha)?;
        d.set_item("energy", reg.energy)?;
        d.set_item("example", reg.example)?;
        d.set_item("iterations", reg.iterations)?;
        Ok(d)
    }

    /// Shape completion of a partial target with feature pairs (template
    /// vertex, partial vertex) by `solver` ("fbt", "der", "amberg",
    /// "template"): `CompletionSolver::solve` as in the harness.
    #[pyo3(signature = (pv, pf, features, solver=None))]
    fn complete<'py>(
        &self,
        py: Python<'py>,
        pv: PyReadonlyArray2<'_, f64>,
        pf: PyReadonlyArray2<'_, i64>,
        features: Vec<(i64, i64)>,
        solver: Option<&str>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let partial = mesh("partial_target", &pv, &pf)?;
        if features.is_empty() {
            return Err(value_err("features: expected at least one feature pair"));
        }
        let s: Vec<i64> = features.iter().map(|p| p.0).collect();
        let t: Vec<i64> = features.iter().map(|p| p.1).collect();
        let s = indices("features (template column)", &s, self.n_vertices())?;
        let t = indices("features (partial column)", &t, partial.n_vertices())?;
        let pairs: Vec<(usize, usize)> = s.into_iter().zip(t).collect();
        let kind = match solver.unwrap_or(SolverKind::default().name()) {
            "fbt" => SolverKind::Fbt,
            "der" => SolverKind::Der,
            "amberg" => SolverKind::Amberg,
            "template" => SolverKind::Template,
            other => {
                return Err(value_err(format!(
                    "solver: unknown value {other:?}; expected fbt, der, amberg or template"
                )))
            }
        };
        let (ex, rig, opts, seed) = (&self.examples, &self.rig, &self.options, self.seed);
        let (out, corr) = py
            .detach(|| {
                let problem = CompletionProblem::from_partial(
                    ex,
                    &partial,
                    &pairs,
                    &FeatureOptions::default(),
                    seed,
                )?
                .with_rig_shapes(rig.clone());
                let out = CompletionSolver::new(kind, opts, seed).solve(&problem)?;
                let corr = deformlab::register::metrics::nearest_points(
                    partial.vertices(),
                    &out.positions,
                )?;
                Ok::<_, Error>((out, corr))
            })
            .map_err(py_err)?;
        let d = PyDict::new(py);
        d.set_item("V", points_array(py, &out.positions))?;
        d.set_item(
            "correspondence",
            PyArray1::from_iter(py, corr.iter().map(|c| c.0 as i64)),
        )?;
        d.set_item(
            "distance",
            PyArray1::from_iter(py, corr.iter().map(|c| c.1)),
        )?;
        d.set_item("alpha", out.alpha)?;
        d.set_item("partial_residual", out.partial_residual)?;
        d.set_item("solver", kind.name())?;
        Ok(d)
    }
}

/// The synthetic set (`deformlab gen`): `(vertices[subject][pose], F, labels)`.
#[pyfunction]
#[pyo3(signature = (subjects=None, poses=None, resolution=None, seed=None))]
#[allow(clippy::type_complexity)]
fn synthetic<'py>(
    py: Python<'py>,
    subjects: Option<usize>,
    poses: Option<usize>,
    resolution: Option<u32>,
    seed: Option<u64>,
) -> PyResult<(
    Vec<Vec<Bound<'py, PyArray2<f64>>>>,
    Bound<'py, PyArray2<i64>>,
    Vec<usize>,
)> {
    let d = FaustStyle::default();
    let cfg = FaustStyle {
        subjects: subjects.unwrap_or(d.subjects),
        poses: poses.unwrap_or(d.poses),
        resolution: resolution.unwrap_or(d.resolution),
        seed: seed.unwrap_or(d.seed),
        ..d
    };
    let set = py.detach(|| cfg.generate()).map_err(py_err)?;
    let verts = set
        .meshes
        .iter()
        .map(|s| s.iter().map(|m| points_array(py, m.vertices())).collect())
        .collect();
    Ok((verts, faces_array(py, set.meshes[0][0].faces()), set.labels))
}

// ---------------------------------------------------------------------------
// Experiments

/// A Python function as a method: `fn(A, poses, B, markers)` with
/// `A = (V, F)`, `poses` a list of `(n, 3)` arrays, `B = (V, F)` and
/// `markers` a list of `(source, target)` pairs or `None`; it returns one
/// `(n_B, 3)` array per pose. Called with the GIL held (one case at a time
/// in Python); an exception fails that case with its message.
fn python_method(name: String, f: Py<PyAny>) -> Arc<CallableFn> {
    Arc::new(
        move |inp: &CallInput| -> deformlab::Result<Vec<Vec<Point>>> {
            Python::attach(|py| {
                let err = |e: PyErr| Error::invalid(format!("{name}: {e}"));
                let a = (
                    points_array(py, inp.a.vertices()),
                    faces_array(py, inp.a.faces()),
                );
                let poses = PyList::empty(py);
                for m in inp.a_def {
                    poses.append(points_array(py, m.vertices())).map_err(err)?;
                }
                let b = (
                    points_array(py, inp.b.vertices()),
                    faces_array(py, inp.b.faces()),
                );
                let markers: Option<Vec<(usize, usize)>> = inp.markers.map(<[_]>::to_vec);
                let r = f.call1(py, (a, poses, b, markers)).map_err(err)?;
                let items = r.bind(py).try_iter().map_err(err)?;
                let mut out = Vec::new();
                for (j, item) in items.enumerate() {
                    let arr: PyReadonlyArray2<'_, f64> =
                        item.map_err(err)?.extract().map_err(|e| {
                            Error::invalid(format!(
                                "{name}: B′ {} is not an (n, 3) float array ({e})",
                                j + 1
                            ))
                        })?;
                    out.push(points("B′", &arr, true).map_err(err)?);
                }
                Ok(out)
            })
        },
    )
}

/// `deformlab run` on config files: one summary dict per experiment.
#[pyfunction]
#[pyo3(signature = (configs, out=None, overrides=None, sweep=None, threads=None,
    data_root=None, plots=true, force=false, retry_failed=false, progress=false, methods=None))]
#[allow(clippy::too_many_arguments)]
fn run<'py>(
    py: Python<'py>,
    configs: Vec<PathBuf>,
    out: Option<PathBuf>,
    overrides: Option<Vec<String>>,
    sweep: Option<Vec<String>>,
    threads: Option<i64>,
    data_root: Option<PathBuf>,
    plots: bool,
    force: bool,
    retry_failed: bool,
    progress: bool,
    methods: Option<Vec<(String, Py<PyAny>)>>,
) -> PyResult<Bound<'py, PyList>> {
    if configs.is_empty() {
        return Err(value_err("config_path: expected at least one config file"));
    }
    let threads = match threads {
        None => deformlab::solve::default_threads(),
        Some(k) if k >= 1 => deformlab::solve::cap_threads(k as usize),
        Some(k) => return Err(value_err(format!("threads: expected at least 1, got {k}"))),
    };
    let opts = RunOptions {
        // The CLI's `--out` default.
        out: out.unwrap_or_else(|| PathBuf::from("results")),
        threads,
        shard: None,
        plots,
        progress,
        max_new: None,
        wait: true,
        defects: Default::default(),
        load: LoadOptions {
            data_root,
            set: overrides.unwrap_or_default(),
            sweep: sweep.unwrap_or_default(),
        },
        force,
        retry_failed,
    };
    // Python functions as `kind = "callable"` methods, registered by name
    // for this run.
    let names: Vec<String> = methods
        .unwrap_or_default()
        .into_iter()
        .map(|(name, f)| {
            register_callable(&name, python_method(name.clone(), f));
            name
        })
        .collect();
    let summaries = py.detach(|| run_configs(&configs, &opts));
    for n in &names {
        unregister_callable(n);
    }
    let summaries = summaries.map_err(py_err)?;
    let list = PyList::empty(py);
    for s in summaries {
        let d = PyDict::new(py);
        d.set_item("name", &s.name)?;
        d.set_item("dir", s.dir)?;
        d.set_item("computed", s.computed)?;
        d.set_item("reused", s.reused)?;
        d.set_item("failed", s.failed)?;
        d.set_item("wall_seconds", s.wall_seconds)?;
        d.set_item("complete", s.complete)?;
        list.append(d)?;
    }
    Ok(list)
}

/// The native module: `__version__` is the library crate's version.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // The solvers' large per-iteration buffers are reused instead of being
    // unmapped and faulted in again (glibc only; see
    // deformlab::solve::keep_freed_memory). Process-wide: the Python
    // process keeps freed memory for reuse. Whether it applied:
    m.add("KEEPS_FREED_MEMORY", deformlab::solve::keep_freed_memory())?;
    m.add("__version__", deformlab::VERSION)?;
    m.add("BINDING_VERSION", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(write_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(inspect, m)?)?;
    m.add_function(wrap_pyfunction!(cotmatrix, m)?)?;
    m.add_function(wrap_pyfunction!(massmatrix, m)?)?;
    m.add_function(wrap_pyfunction!(lbo_eigenpairs, m)?)?;
    m.add_function(wrap_pyfunction!(heat_geodesic, m)?)?;
    m.add_function(wrap_pyfunction!(fps, m)?)?;
    m.add_function(wrap_pyfunction!(bbw, m)?)?;
    m.add_function(wrap_pyfunction!(select_keypoints, m)?)?;
    m.add_function(wrap_pyfunction!(transfer, m)?)?;
    m.add_function(wrap_pyfunction!(method_kinds, m)?)?;
    m.add_function(wrap_pyfunction!(target_correspondence, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(synthetic, m)?)?;
    m.add_class::<PyFbtModel>()?;
    Ok(())
}

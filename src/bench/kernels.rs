//! Benchmarks of the numerical core, as plain functions that return a printed
//! table (`deformlab bench` calls [`run`] through [`super::run`]). Medians
//! over repeated runs: at least 5 repetitions for the small size, 3 for the
//! larger ones (1 for the slow nalgebra-sparse comparison at 50k).
//!
//! Meshes are tori `torus(1.0, 0.5, nu, nv)` with `nu = 2 nv`, so triangles
//! are nearly uniform: 120×60 = **7 200**, 316×158 = **49 928** and
//! 632×316 = **199 712** vertices.
//!
//! Groups (`which` names, all when empty):
//! * `ops` — cotangent Laplacian + Voronoi mass assembly;
//! * `cholesky` — `L + εM` (ε = 1e-3): symbolic + numeric factorisation, then 3
//!   single right-hand-side solves;
//! * `biharmonic` — the full biharmonic matrix `L M⁻¹ L + εM` (ε = 1e-3, no
//!   pinned rows; the torus is closed): assembly (sparse product),
//!   factorisation, 3 solves;
//! * `eigen` — 20 smallest LBO eigenpairs at 7k and 50k (verified);
//! * `nalgebra` — nalgebra-sparse's `CscCholesky` on the same `L + εM` and
//!   biharmonic matrices at 7k and 50k, in the mesh's natural vertex order
//!   (nalgebra-sparse has no fill-reducing ordering; the torus order is
//!   banded, bandwidth ≈ 2·nv).

use std::fmt::Write as _;

use nalgebra::DMatrix;

use crate::mesh::primitives::torus;
use crate::mesh::Mesh;
use crate::ops::{cotan_laplacian, mass_matrix, MassKind};
use crate::solve::{
    generalized_eigen, sparse_diagonal, EigenOptions, SparseCholesky, SparseMatrix,
};
use crate::{Error, Result};

use super::time;

/// Benchmark group names accepted by [`run`].
pub const GROUPS: [&str; 5] = ["ops", "cholesky", "biharmonic", "eigen", "nalgebra"];

/// Torus sizes `(nu, nv)`.
const SIZES: [(usize, usize); 3] = [(120, 60), (316, 158), (632, 316)];

fn bench_mesh(nu: usize, nv: usize) -> Mesh {
    torus(1.0, 0.5, nu, nv)
}

fn plus_eps_mass(a: &SparseMatrix, m: &[f64], eps: f64) -> SparseMatrix {
    a + &sparse_diagonal(&m.iter().map(|x| eps * x).collect::<Vec<_>>())
}

fn biharmonic(l: &SparseMatrix, m: &[f64]) -> SparseMatrix {
    let minv = sparse_diagonal(&m.iter().map(|x| 1.0 / x).collect::<Vec<_>>());
    let lml = &(l * &minv) * l;
    plus_eps_mass(&lml, m, 1e-3)
}

fn rhs(n: usize, j: usize) -> Vec<f64> {
    (0..n)
        .map(|i| (((i * 7919 + j * 104_729) % 1009) as f64) / 504.5 - 1.0)
        .collect()
}

/// Runs the named groups (all if `which` is empty) and returns the table.
/// `quick` runs the 7k size only (fewer repetitions). Timings use the current
/// [`crate::solve::set_threads`] setting (sequential by default).
pub fn run(which: &[String], quick: bool) -> Result<String> {
    for w in which {
        if !GROUPS.contains(&w.as_str()) {
            return Err(Error::invalid(format!(
                "unknown benchmark group {w:?} (known: {})",
                GROUPS.join(", ")
            )));
        }
    }
    let want = |g: &str| which.is_empty() || which.iter().any(|w| w == g);
    let sizes: &[(usize, usize)] = if quick { &SIZES[..1] } else { &SIZES };
    let reps = |i: usize| if i == 0 { 5 } else { 3 };
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| job | vertices | median (s) | reps | notes |\n|---|---|---|---|---|"
    );
    let mut row = |job: &str, n: usize, t: f64, r: usize, note: &str| {
        let _ = writeln!(out, "| {job} | {n} | {t:.4} | {r} | {note} |");
    };
    for (si, &(nu, nv)) in sizes.iter().enumerate() {
        let mesh = bench_mesh(nu, nv);
        let n = mesh.n_vertices();
        let r = reps(si);
        if want("ops") {
            let (t, _) = time(r, || {
                Ok((
                    cotan_laplacian(&mesh),
                    mass_matrix(&mesh, MassKind::Voronoi),
                ))
            })?;
            row("cotan L + Voronoi mass", n, t, r, "");
        }
        let l = cotan_laplacian(&mesh);
        let m = mass_matrix(&mesh, MassKind::Voronoi);
        let a = plus_eps_mass(&l, &m, 1e-3);
        let mut systems: Vec<(&str, SparseMatrix)> = Vec::new();
        if want("cholesky") {
            systems.push(("L + 1e-3 M", a.clone()));
        }
        if want("biharmonic") {
            let (t, _) = time(r, || Ok(biharmonic(&l, &m)))?;
            row(
                "biharmonic assembly L M⁻¹ L + 1e-3 M",
                n,
                t,
                r,
                "sparse product",
            );
            systems.push(("L M⁻¹ L + 1e-3 M", biharmonic(&l, &m)));
        }
        for (name, sys) in &systems {
            let (t, _) = time(r, || SparseCholesky::new(sys))?;
            let chol = SparseCholesky::new(sys)?;
            row(
                &format!("faer LLᵀ factorise {name}"),
                n,
                t,
                r,
                &format!("AMD, factor nnz {}", chol.symbolic().factor_nnz()),
            );
            let bs: Vec<Vec<f64>> = (0..3).map(|j| rhs(n, j)).collect();
            let (t, _) = time(r, || {
                bs.iter()
                    .map(|b| chol.try_solve_vec(b))
                    .collect::<Result<Vec<_>>>()
            })?;
            let x = chol.try_solve_vec(&bs[0])?;
            let ax = sys * &DMatrix::from_column_slice(n, 1, &x);
            let res = (ax - DMatrix::from_column_slice(n, 1, &bs[0])).norm()
                / bs[0].iter().map(|v| v * v).sum::<f64>().sqrt();
            row(
                &format!("faer 3 solves {name}"),
                n,
                t,
                r,
                &format!("rel. residual {res:.1e}"),
            );
        }
        if want("eigen") && si < 2 {
            let mut info = String::new();
            let (t, _) = time(r, || {
                let e = generalized_eigen(&l, &m, 20, &EigenOptions::default())?;
                info = format!(
                    "max residual {:.1e}, orth. {:.1e}, λ1..3 ≈ {:.4}",
                    e.max_residual, e.orthonormality_error, e.values[1]
                );
                Ok(e)
            })?;
            row("20 LBO eigenpairs (verified)", n, t, r, &info);
        }
        if want("nalgebra") && si < 2 {
            let nr = if si == 0 { 5 } else { 1 };
            let mut mats = vec![("L + 1e-3 M", a.clone())];
            mats.push(("L M⁻¹ L + 1e-3 M", biharmonic(&l, &m)));
            for (name, sys) in &mats {
                let (t, _) = time(nr, || {
                    nalgebra_sparse::factorization::CscCholesky::factor(sys)
                        .map_err(|e| Error::numerical(format!("nalgebra-sparse Cholesky: {e}")))
                })?;
                let f = nalgebra_sparse::factorization::CscCholesky::factor(sys)
                    .map_err(|e| Error::numerical(format!("nalgebra-sparse Cholesky: {e}")))?;
                row(
                    &format!("nalgebra-sparse factorise {name}"),
                    n,
                    t,
                    nr,
                    &format!("natural order, factor nnz {}", f.l().nnz()),
                );
                let bs: Vec<DMatrix<f64>> =
                    (0..3).map(|j| DMatrix::from_vec(n, 1, rhs(n, j))).collect();
                let (t, _) = time(nr, || Ok(bs.iter().map(|b| f.solve(b)).collect::<Vec<_>>()))?;
                row(&format!("nalgebra-sparse 3 solves {name}"), n, t, nr, "");
            }
        }
    }
    Ok(out)
}

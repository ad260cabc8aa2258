//! Timing of skinning weights and linear blend skinning (BDT Table 1,
//! columns SWT/h and LBS time).
//!
//! `run(quick)` reads FAUST `tr_reg_001.ply` from the shared data folder
//! (or, when absent, uses an icosphere of 10 242 vertices and says so),
//! places handles by farthest point sampling (Euclidean, seed 0), and reports
//! medians over repetitions of: bounded biharmonic weights in every mode
//! (precomputation of `Q` included and also shown separately) and LBS of all
//! vertices × 12 handles, directly and through the precomputed operator.
//! This module does file I/O (it reads the mesh) and is not used by the
//! algorithms.

use std::fmt::Write as _;
use std::time::Instant;

use nalgebra::DMatrix;

use crate::mesh::io::read_mesh;
use crate::mesh::primitives::icosphere;
use crate::ops::{farthest_point_sampling, FpsMetric};
use crate::skin::bbw::{BbwOptions, Biharmonic, WeightMode};
use crate::skin::lbs::{lbs, transforms_to_stacked, Affine, LbsMatrix};
use crate::{Mesh, Result};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_unstable_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Median wall time (s) of `f` over `reps` runs and the last result.
fn time<T>(reps: usize, mut f: impl FnMut() -> Result<T>) -> Result<(f64, T)> {
    let mut times = Vec::with_capacity(reps);
    let mut last = None;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let r = f()?;
        times.push(t.elapsed().as_secs_f64());
        last = Some(r);
    }
    let last = last.ok_or_else(|| crate::Error::invalid("no repetitions"))?;
    Ok((median(times), last))
}

fn bench_mesh(out: &mut String) -> Result<Mesh> {
    let path = crate::data::shared_data_dir().map(|d| d.join("faust/tr_reg_001.ply"));
    match path {
        Some(p) if p.exists() => {
            let m = read_mesh(&p)?;
            let _ = writeln!(out, "mesh: {} ({} vertices)", p.display(), m.n_vertices());
            Ok(m)
        }
        _ => {
            let m = icosphere(5);
            let _ = writeln!(
                out,
                "mesh: FAUST tr_reg_001.ply not found; using icosphere(5) ({} vertices)",
                m.n_vertices()
            );
            Ok(m)
        }
    }
}

/// Runs the benchmark and returns the report (Markdown table), medians of 3
/// runs. `quick` uses 4 handles instead of 10.
pub fn run(quick: bool) -> Result<String> {
    let mut out = String::new();
    let mesh = bench_mesh(&mut out)?;
    let n = mesh.n_vertices();
    let reps = 3;
    let nh = if quick { 4 } else { 10 };
    let handles = farthest_point_sampling(&mesh, nh, FpsMetric::Euclidean, 0)?;
    let _ = writeln!(
        out,
        "handles: {nh} by farthest point sampling (seed 0); medians of {reps} runs\n"
    );
    let _ = writeln!(out, "| job | total (s) | per handle (s) | notes |");
    let _ = writeln!(out, "|---|---|---|---|");
    let (t_pre, bh) = time(reps, || Biharmonic::new(&mesh))?;
    let _ = writeln!(
        out,
        "| precompute L, M, Q = L M⁻¹ L | {t_pre:.3} | – | once per mesh |"
    );
    let mut weights_for_lbs: Option<DMatrix<f64>> = None;
    for (name, mode) in [
        ("Unbounded (equality only)", WeightMode::Unbounded),
        ("PerHandle (active set + normalise)", WeightMode::PerHandle),
        (
            "Coupled (PerHandle + support active set, Eq. 1)",
            WeightMode::Coupled,
        ),
    ] {
        let opts = BbwOptions::with_mode(mode);
        let (t, rep) = time(reps, || bh.weights_with_report(&handles, &opts))?;
        let w = &rep.weights;
        let max_row_err = (0..n)
            .map(|i| (w.row(i).sum() - 1.0).abs())
            .fold(0.0f64, f64::max);
        let (lo, hi) = (w.min(), w.max());
        let energy = bh.energy(w)?;
        let _ = writeln!(
            out,
            "| weights, {name} | {t:.3} | {:.4} | {} factorisations, {} iterations ({} coupled, \
             {} unknowns), energy {energy:.6e}, range [{lo:.2e}, {hi:.6}], max |row sum − 1| \
             {max_row_err:.1e} |",
            t / nh as f64,
            rep.factorizations,
            rep.iterations,
            rep.coupled_iterations,
            rep.coupled_unknowns,
        );
        if mode == WeightMode::Coupled {
            weights_for_lbs = Some(rep.weights);
        }
    }
    let _ = writeln!(
        out,
        "| reference: libigl bbw active set (no partition of unity) | – | 0.21 | measured \
         on this machine before the project |"
    );
    // LBS with 12 handles.
    let lbs_handles = farthest_point_sampling(&mesh, 12, FpsMetric::Euclidean, 1)?;
    let w12 = match weights_for_lbs {
        Some(w) if w.ncols() == 12 => w,
        _ => bh.weights(&lbs_handles, &BbwOptions::with_mode(WeightMode::Unbounded))?,
    };
    let transforms: Vec<Affine> = (0..12)
        .map(|k| {
            let a = 0.1 * k as f64;
            Affine::new(
                a.cos(),
                -a.sin(),
                0.0,
                0.01 * k as f64,
                a.sin(),
                a.cos(),
                0.0,
                0.0,
                0.0,
                0.0,
                1.0,
                -0.02 * k as f64,
            )
        })
        .collect();
    let lbs_reps = 51;
    let (t_direct, _) = time(lbs_reps, || lbs(mesh.vertices(), &w12, &transforms))?;
    let op = LbsMatrix::new(mesh.vertices(), &w12)?;
    let stacked = transforms_to_stacked(&transforms);
    let (t_op, _) = time(lbs_reps, || op.apply_stacked(&stacked))?;
    let (t_build, _) = time(reps, || LbsMatrix::new(mesh.vertices(), &w12))?;
    let _ = writeln!(
        out,
        "| LBS {n} v × 12 handles, `skin::lbs` | {:.3} ms | – | median of {lbs_reps} |",
        t_direct * 1e3
    );
    let _ = writeln!(
        out,
        "| LBS {n} v × 12 handles, `LbsMatrix::apply_stacked` | {:.3} ms | – | operator \
         build {:.3} ms (once) |",
        t_op * 1e3,
        t_build * 1e3
    );
    Ok(out)
}

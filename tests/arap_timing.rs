//! Timing of the reduced ARAP solver on a ~7k-vertex mesh (ignored by
//! default; run with
//! `cargo test --release --test arap_timing -- --ignored --nocapture`).

use std::time::Instant;

use deformlab::arap::{ArapOptions, ReducedArap};
use deformlab::mesh::primitives::torus;
use deformlab::ops::rotation::rotation_exp_axis_angle;
use deformlab::skin::groups::{rotation_groups, GroupFeatures};
use deformlab::{Mesh, Point, Vec3};
use nalgebra::DMatrix;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn weights(m: &Mesh, nh: usize) -> (DMatrix<f64>, Vec<usize>) {
    let n = m.n_vertices();
    let handles: Vec<usize> = (0..nh).map(|k| (k * n) / nh + (k * 7) % 50).collect();
    let v = m.vertices();
    let mut w = DMatrix::from_fn(n, nh, |i, k| {
        let d2 = (v[i] - v[handles[k]]).norm_squared();
        (-d2 / 0.2).exp() + 1e-8
    });
    for i in 0..n {
        let s: f64 = w.row(i).sum();
        w.row_mut(i).scale_mut(1.0 / s);
    }
    (w, handles)
}

fn target(m: &Mesh, amount: f64) -> Vec<Point> {
    m.vertices()
        .iter()
        .map(|p| {
            let r = rotation_exp_axis_angle(&Vec3::new(amount * p.x, 0.0, 0.0));
            Point::from(r * p.coords)
        })
        .collect()
}

#[test]
#[ignore]
fn timing_7k() {
    let m = torus(1.0, 0.4, 120, 58);
    println!("mesh: {} vertices", m.n_vertices());
    for nh in [10usize, 20] {
        let (w, handles) = weights(&m, nh);
        let groups = rotation_groups(&m, &[], &w, GroupFeatures::Weights, None, 1).unwrap();
        for ediff in [true, false] {
            let opts = ArapOptions {
                use_ediff: ediff,
                handles: handles.clone(),
                ..ArapOptions::default()
            };
            let mut pre = Vec::new();
            let mut arap = None;
            for _ in 0..5 {
                let t = Instant::now();
                arap = Some(ReducedArap::new(&m, &w, &groups, opts.clone()).unwrap());
                pre.push(t.elapsed().as_secs_f64());
            }
            let arap = arap.unwrap();
            let q = target(&m, 0.6);
            let mut solve = Vec::new();
            let mut iters = 0;
            for _ in 0..11 {
                let t = Instant::now();
                let s = arap.solve(&q, None).unwrap();
                solve.push(t.elapsed().as_secs_f64());
                iters = s.iterations;
            }
            // Per-iteration cost: two iteration counts (rel_tol 0 stops
            // only when the energy stops decreasing), difference.
            let fixed = |k: usize| {
                let o = ArapOptions {
                    max_iter: k,
                    rel_tol: 0.0,
                    ..opts.clone()
                };
                let a = ReducedArap::new(&m, &w, &groups, o).unwrap();
                let mut it = 0;
                let v: Vec<f64> = (0..7)
                    .map(|_| {
                        let t = Instant::now();
                        it = a.solve(&q, None).unwrap().iterations;
                        t.elapsed().as_secs_f64()
                    })
                    .collect();
                (median(v), it)
            };
            let ((t1, i1), (tk, ik)) = (fixed(1), fixed(200));
            println!(
                "n_h {nh:2} |G| {:2} ediff {ediff:5}: precompute {:.1} ms, solve {:.2} ms \
                 ({iters} iterations); per iteration {:.1} µs (from {i1} vs {ik} iterations), \
                 fixed per-solve overhead {:.2} ms",
                arap.n_groups(),
                1e3 * median(pre),
                1e3 * median(solve),
                1e6 * (tk - t1) / (ik - i1).max(1) as f64,
                1e3 * t1,
            );
        }
    }
}

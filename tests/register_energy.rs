//! FBT energies and their optimisation on the synthetic TOSCA-style class.

use std::sync::Arc;

use deformlab::register::*;
use deformlab::skin::lbs::points_to_matrix;
use deformlab::Mesh;
use nalgebra::DMatrix;

fn class() -> Vec<Mesh> {
    synthetic_class(1, 0).unwrap()
}

#[test]
fn explore() {
    let meshes = class();
    eprintln!("n = {}", meshes[0].n_vertices());
    let examples: Vec<Mesh> = meshes[1..5].to_vec();
    let t0 = std::time::Instant::now();
    let setup = build(&examples, &FbtConfig::default()).unwrap();
    eprintln!(
        "setup {:.3}s sizes {:?}",
        t0.elapsed().as_secs_f64(),
        setup.sizes
    );
    let target = &meshes[7];
    let feats = deformlab::data::partial::feature_points(target, 8, 1).unwrap();
    let area = setup.graph.area();
    let radii = circle_radii(10, 0.15 * area.sqrt());
    let pairs: Vec<(usize, usize)> = feats.iter().map(|&f| (f, f)).collect();
    let (rows, y) = feature_circle_constraints(&examples[0], target, &pairs, &radii).unwrap();
    let params = FbtParams::default();
    let sys = setup.pipeline.systems(&rows, &params).unwrap();
    let t1 = std::time::Instant::now();
    let reg = sys.solve(&y, &Schedule::default()).unwrap();
    eprintln!(
        "solve {:.4}s iters {} example {} alpha {}",
        t1.elapsed().as_secs_f64(),
        reg.iterations,
        reg.example,
        reg.alpha
    );
    for (n, tr) in &reg.stage_traces {
        eprintln!("{n}: {:?}", tr);
    }
    let d = metrics::relative_distortion(&reg.positions, target.vertices(), area).unwrap();
    eprintln!("mean {:.4} max {:.4}", metrics::mean(&d), metrics::max(&d));
    // init only
    let tinit = sys.initial(&y, Schedule::default().init).unwrap();
    let p = sys.main.positions(&tinit).unwrap();
    let d = metrics::relative_distortion(&p, target.vertices(), area).unwrap();
    eprintln!(
        "init mean {:.4} max {:.4}",
        metrics::mean(&d),
        metrics::max(&d)
    );
    // nearest example
    for (l, e) in examples.iter().enumerate() {
        let d = metrics::relative_distortion(e.vertices(), target.vertices(), area).unwrap();
        eprintln!("example {l} mean {:.4}", metrics::mean(&d));
    }
    let _ = (
        Arc::new(0),
        points_to_matrix(&[]),
        DMatrix::<f64>::zeros(1, 1),
    );
}

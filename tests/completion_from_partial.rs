//! `CompletionProblem::from_partial` (the Python binding's `complete`)
//! builds the problem `CompletionProblem::new` builds when given the same
//! partial target and feature pairs, so every solver gives the same result.

use deformlab::methods::completion::{
    CompletionProblem, CompletionSolver, FbtOptions, FeatureOptions, PipelineKind, SolverKind,
};
use deformlab::register::synthetic_class;

#[test]
fn from_partial_is_the_problem_of_new_on_its_partial_target() {
    let meshes = synthetic_class(1, 0).unwrap();
    let examples = &meshes[..3];
    let target = &meshes[6];
    let feats = FeatureOptions::default();
    let p = CompletionProblem::new(examples, target, &feats, 5).unwrap();
    let pairs: Vec<(usize, usize)> = p
        .features()
        .iter()
        .zip(&p.partial().features)
        .map(|(&f, &g)| (f, g))
        .collect();
    let q =
        CompletionProblem::from_partial(examples, &p.partial().mesh, &pairs, &feats, 5).unwrap();
    assert_eq!(p.rows(), q.rows());
    assert_eq!(p.y(), q.y());
    assert_eq!(p.area(), q.area());
    let opts = FbtOptions {
        pipeline: PipelineKind::Lbo,
        ..FbtOptions::default()
    };
    for kind in [SolverKind::Fbt, SolverKind::Amberg] {
        let s = CompletionSolver::new(kind, &opts, 5);
        assert_eq!(
            s.solve(&p).unwrap().positions,
            s.solve(&q).unwrap().positions,
            "{kind:?}"
        );
    }
}

#[test]
fn from_partial_refuses_bad_pairs() {
    let meshes = synthetic_class(1, 0).unwrap();
    let n = meshes[0].n_vertices();
    let feats = FeatureOptions::default();
    let e = CompletionProblem::from_partial(&meshes[..2], &meshes[3], &[(0, n)], &feats, 0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("out of range"), "{e}");
    let e = CompletionProblem::from_partial(&meshes[..2], &meshes[3], &[], &feats, 0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("feature pair"), "{e}");
}
